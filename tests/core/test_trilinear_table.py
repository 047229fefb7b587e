"""The trilinear topology's table, key by key: closed patches whose boundary is the loops, 2-manifold at every
vertex, outward winding consistent, each face's segments decided by that face alone, the patches' Euler
characteristic (a disk per loop, an annulus per tube), and today's triangles wherever nothing is ambiguous."""
import itertools
from collections import Counter

import numpy as np
import pytest

from isoscope.core.case_table import EDGE_CORNERS, EDGE_FACES, FACE_CORNERS, montani_table
from isoscope.core.trilinear_table import (
    FIRST_CELL_VERTEX,
    TUNNEL_KEYS,
    ambiguous_faces,
    cell_triangles,
    face_keys_of,
    loops,
    surface_regions,
    table_key,
    trilinear_table,
    tunnel_corners,
)


def every_key():
    for case in range(256):
        for face_key in face_keys_of(case):
            for tunnel in range(TUNNEL_KEYS):
                yield case, face_key, tunnel


KEYS = list(every_key())


def has_tube(case, face_key, tunnel):
    corners = tunnel_corners(case, tunnel)
    regions = surface_regions(case, face_key)
    return corners is not None and regions[corners[0]] != regions[corners[1]]


def directed(triangles):
    return Counter((t[k], t[(k + 1) % 3]) for t in triangles for k in range(3))


def test_every_key_is_a_manifold_patch_bounded_by_its_loops():
    tubes = 0
    for key in KEYS:
        triangles, own = cell_triangles(*key)
        edges = directed(triangles)
        assert max(edges.values(), default=1) == 1, key  # no directed edge twice: consistent winding
        boundary = {e for e in edges if (e[1], e[0]) not in edges}
        segments = {(loop[i], loop[(i + 1) % len(loop)]) for loop in loops(*key[:2]) for i in range(len(loop))}
        assert boundary == segments, key
        # Every vertex's neighbours form one path (edge vertices) or one cycle (the cell's own): no pinch.
        for vertex in {c for t in triangles for c in t}:
            ring = {(t[(t.index(vertex) + 1) % 3], t[(t.index(vertex) + 2) % 3]) for t in triangles if vertex in t}
            nxt = dict(ring)
            assert len(nxt) == len(ring), (key, vertex)
            starts = set(nxt) - set(nxt.values())
            start = next(iter(starts)) if starts else next(iter(nxt))
            seen, at = [start], start
            while at in nxt and nxt[at] != start:
                at = nxt[at]
                seen.append(at)
            assert len(seen) == len(ring) + (1 if starts else 0), (key, vertex)
            assert (vertex >= FIRST_CELL_VERTEX) == (not starts), (key, vertex)
        # A new edge never lies in a cube face (the neighbour might draw it too).
        for a, b in edges:
            if a < FIRST_CELL_VERTEX and b < FIRST_CELL_VERTEX and (a, b) not in segments and (b, a) not in segments:
                assert not (EDGE_FACES[a] & EDGE_FACES[b]), (key, a, b)
        # Own vertices sit at the mean of edges not all on one face: inside the cell.
        for edges_of_vertex in own:
            assert not frozenset.intersection(*(EDGE_FACES[e] for e in edges_of_vertex)), key
        vertices = {c for t in triangles for c in t}
        undirected = {frozenset(e) for e in edges}
        tube = has_tube(*key)
        tubes += tube
        assert len(vertices) - len(undirected) + len(triangles) == len(loops(*key[:2])) - 2 * tube, key
    assert tubes > 100  # the tunnels are there to be checked


def face_segments(case, face_key, face):
    """The segments a key draws on one face, as pairs of the face's side numbers (0..3 around its cycle)."""
    cycle = FACE_CORNERS[face]
    sides = {}
    for m in range(4):
        pair = {cycle[m], cycle[(m + 1) % 4]}
        for e in range(12):
            if set(EDGE_CORNERS[e]) == pair:
                sides[e] = m
    triangles, _ = cell_triangles(case, face_key, 0)
    return frozenset(frozenset((sides[a], sides[b])) for t in triangles for a, b in itertools.combinations(t, 2)
                     if a in sides and b in sides)


def test_a_faces_segments_depend_on_that_face_alone():
    """Two cells sharing a face see its four corners and its decision alike: they must draw the same
    segments there, whatever else differs (no cracks)."""
    seen = {}
    for case, face_key, tunnel in KEYS:
        if tunnel:
            continue
        for face in range(6):
            corners = tuple(case >> c & 1 for c in FACE_CORNERS[face])
            decided = (corners, bool(face_key >> face & 1) and face in ambiguous_faces(case))
            segments = face_segments(case, face_key, face)
            assert seen.setdefault(decided, segments) == segments, (case, face_key, face)
    assert len(seen) == 16 + 2  # every corner pattern, and the two checkerboards decided both ways


def test_unambiguous_keys_are_todays_triangles():
    montani = montani_table()
    table = trilinear_table()
    for case in range(256):
        today = [tuple(t) for t in montani.triangles[case, : montani.counts[case]]]
        key = table_key(case, 0, 0)
        assert [tuple(t) for t in table.triangles[key, : table.counts[key]]] == today
        assert not table.cell_vertices[key].any()


def test_the_packed_table_is_the_keys():
    table = trilinear_table()
    for key in KEYS[::7]:
        triangles, own = cell_triangles(*key)
        k = table_key(*key)
        assert [tuple(t) for t in table.triangles[k, : table.counts[k]]] == list(triangles)
        assert [m for m in table.cell_vertices[k] if m] == [sum(1 << e for e in edges) for edges in own]


@pytest.mark.parametrize("case", [0b10000001, 0b01111110])
def test_case_4_has_a_tube_only_when_the_interior_joins_it(case):
    inside_side = 1 if case == 0b10000001 else 3
    assert not has_tube(case, 0, 0)
    assert has_tube(case, 0, inside_side)
    assert len(cell_triangles(case, 0, 0)[0]) == 2
    assert len(cell_triangles(case, 0, inside_side)[0]) == 6
    assert np.all(trilinear_table().counts[table_key(case, 0, np.arange(TUNNEL_KEYS))] >= 2)

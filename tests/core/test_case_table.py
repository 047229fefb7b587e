"""The generated table: face consistency across all 256 cases, closed patches, winding."""
import itertools

import numpy as np
import pytest

from isoscope.core.case_table import (
    CORNER_OFFSETS,
    EDGE_CORNERS,
    EDGE_MIDPOINT,
    FACE_CORNERS,
    label_table,
    montani_table,
)

TABLE = montani_table()
TABLES = {"montani": montani_table(), "labels": label_table()}


def triangles_of(case, table=TABLE):
    return [tuple(t) for t in table.triangles[case, : table.counts[case]]]


def edge_endpoints(e):
    lo, hi = EDGE_CORNERS[e]
    return tuple(CORNER_OFFSETS[lo]), tuple(CORNER_OFFSETS[hi])


def face_of_segment(a, b):
    """The cube face containing both cell edges, or None."""
    for f, corners in enumerate(FACE_CORNERS):
        if set(EDGE_CORNERS[a]) <= set(corners) and set(EDGE_CORNERS[b]) <= set(corners):
            return f
    return None


def segments_on_faces(case, table=TABLE):
    """Directed triangle edges that lie in a cube face, keyed by face, from the triangles alone."""
    out = {f: set() for f in range(6)}
    for t in triangles_of(case, table):
        for a, b in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0])):
            f = face_of_segment(a, b)
            if f is not None:
                out[f].add((a, b))
    return out


def crossed_edges(case):
    return {e for e in range(12) if (case >> EDGE_CORNERS[e][0] & 1) != (case >> EDGE_CORNERS[e][1] & 1)}


def mirror_edge(e, axis):
    """The same grid edge seen from the neighbouring cell across a face normal to `axis`."""
    lo, hi = edge_endpoints(e)
    lo, hi = list(lo), list(hi)
    lo[axis] = 1 - lo[axis]
    hi[axis] = 1 - hi[axis]
    for other in range(12):
        if {tuple(lo), tuple(hi)} == set(edge_endpoints(other)):
            return other
    raise AssertionError


@pytest.mark.parametrize("name", TABLES)
def test_table_uses_exactly_the_crossed_edges(name):
    for case in range(256):
        used = {e for t in triangles_of(case, TABLES[name]) for e in t}
        assert used == crossed_edges(case), case


def cone_volume(case, table):
    """Signed volume from the cell centre to the case's triangles at edge midpoints."""
    points = EDGE_MIDPOINT - 0.5
    return sum(np.linalg.det(points[list(t)]) for t in triangles_of(case, table)) / 6


def test_label_table_draws_the_same_face_segments_and_never_encloses_less():
    """The label table only refolds loops: on every face it draws what the extractor's table draws
    (so the two agree across cell faces, and inherit its proof below), and it encloses at least as
    much in every case, strictly more in some (the corners of a voxel staircase cut less)."""
    labels, gained = TABLES["labels"], 0
    for case in range(256):
        assert segments_on_faces(case, labels) == segments_on_faces(case), case
        assert labels.counts[case] == TABLE.counts[case]
        more = cone_volume(case, labels) - cone_volume(case, TABLE)
        assert more > -1e-12, case
        gained += more > 1e-6
    assert gained >= 40, gained


def test_every_face_agrees_with_every_neighbour():
    """For all 256 x 256 pairs of cells sharing a face with the same four corner signs, both cells
    draw the same segments on it, in opposite directions: the surface cannot crack."""
    checked = 0
    segments = [segments_on_faces(case) for case in range(256)]   # each case's, once
    for axis in range(3):
        low_face, high_face = 2 * axis, 2 * axis + 1
        for a, b in itertools.product(range(256), repeat=2):
            # Cell A's high face is cell B's low face: corners there must match.
            a_corners = [c for c in range(8) if CORNER_OFFSETS[c][axis] == 1]
            if any((a >> c & 1) != (b >> (c ^ (1 << axis)) & 1) for c in a_corners):
                continue
            seg_a = segments[a][high_face]
            seg_b = {(mirror_edge(p, axis), mirror_edge(q, axis)) for p, q in segments[b][low_face]}
            assert seg_a == {(q, p) for p, q in seg_b}, (axis, a, b)
            checked += 1
    assert checked == 3 * 256 * 16


@pytest.mark.parametrize("name", TABLES)
@pytest.mark.parametrize("case", range(256))
def test_each_case_patch_is_a_manifold_with_boundary_on_the_faces(case, name):
    """Inside a cell every triangle edge is shared by two triangles; edges used once lie in a face."""
    counts = {}
    for t in triangles_of(case, TABLES[name]):
        for a, b in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0])):
            counts[frozenset((a, b))] = counts.get(frozenset((a, b)), 0) + 1
    for edge, n in counts.items():
        a, b = tuple(edge)
        assert n in (1, 2), (case, edge, n)
        assert (n == 1) == (face_of_segment(a, b) is not None), (case, edge, n)


@pytest.mark.parametrize("name", TABLES)
@pytest.mark.parametrize("case", range(1, 256))
def test_each_case_alone_in_a_volume_closes_outwards(case, name):
    """The case's eight corners inside an otherwise empty 4^3 volume: a closed, consistently wound
    surface enclosing positive volume (so triangles face out of the object)."""
    from support.mesh_checks import assert_closed_manifold, signed_volume

    from isoscope.cpu.cubes import marching_cubes_reference

    volume = np.full((4, 4, 4), -1.0, dtype=np.float32)
    for c in range(8):
        d0, d1, d2 = CORNER_OFFSETS[c]
        volume[1 + d0, 1 + d1, 1 + d2] = 1.0 if case >> c & 1 else -1.0
    verts, faces, normals, _ = marching_cubes_reference(volume, 0.0, table=TABLES[name])
    assert_closed_manifold(faces)
    assert signed_volume(verts, faces) > 0


def test_ambiguous_faces_separate_inside_corners():
    """Montani's rule: on a checkerboard face the two inside corners are never joined."""
    case = (1 << 0) | (1 << 3)  # corners 0 and 3 are diagonal on face axis2 = 0
    segments = segments_on_faces(case)[4]
    assert len(segments) == 2
    for a, b in segments:
        shared = set(EDGE_CORNERS[a]) & set(EDGE_CORNERS[b])
        assert shared and (case >> shared.pop() & 1)  # each segment cuts off one inside corner

"""The case table of the trilinear interpolant's topology (``topology="trilinear"``), generated from rules.

Today's table (`case_table.montani_table`) decides every ambiguous face one way and triangulates each loop
as a disk.  The surface of the trilinear interpolant inside a cell is decided by three things, each a key
of this table:

1. **The case**: which of the eight corners are inside (as in `case_table`).
2. **The faces**: on a face whose corners alternate (the checkerboard), the bilinear interpolant's saddle
   joins either the two inside corners or the two outside ones (the asymptotic decider, Nielsen and
   Hamann 1991).  Bit ``f`` of the face key is set when face ``f`` joins its inside corners.  Two cells
   that share a face read the same four samples and take the same decision (`isoscope.cpu.trilinear`
   decides it), so the mesh has no cracks.
3. **The tunnel**: sweeping a plane along axis 2 through the cell, each section is bilinear; the inside of
   the cell is connected beyond what its faces show only through a section's saddle, and the sections'
   saddle value is a quadratic in the plane's height with one interior extremum.  The section there
   joins at most one pair of corners that the faces keep apart: then the surface is a
   tube (an annulus) between two loops instead of two disks (MC33's 4.1.2, 6.1.2, 7.4.2, 10.1.2, 12.1.2,
   13.5.2 and their kin; Chernyaev 1995, Lopes and Brodlie 2003).  The tunnel key names the section's
   joined diagonal: 0 none, 1 inside corners of vertical edges 0 and 3, 2 inside 1 and 2, 3 outside 0 and
   3, 4 outside 1 and 2 (vertical edge ``i`` runs from corner ``i`` to corner ``i + 4``).

Everything else is `case_table`'s: loops of oriented face segments, each disk triangulated with no
diagonal in a cube face, the largest smallest angle at edge midpoints; a tube is a zipper of triangles
between its two loops under the same rules.  Vertices stay on cell edges (the extractors' edge vertices
are today's), but for the few cells where no triangulation on them keeps every new edge off the faces:
those take vertices of their own, each the mean of listed edge vertices (`FIRST_CELL_VERTEX`).
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass
from functools import cache

import numpy as np

from .case_table import (
    EDGE_CORNERS,
    EDGE_FACES,
    EDGE_MIDPOINT,
    FACE_CORNERS,
    _loops,
    _max_angle_score,
    _triangle_min_angle,
    _triangulate,
    smallest_angle,
)

TOPOLOGIES = ("montani", "trilinear")
"""montani: every ambiguous face decided one way (case_table: fast, watertight); trilinear: the field's own."""


def topology_problem(topology) -> str | None:
    """What is wrong with a topology's name, in the one wording every door uses, or None."""
    if topology not in TOPOLOGIES:
        return f"unknown topology {topology!r}; use one of {', '.join(TOPOLOGIES)}"
    return None


TUNNEL_KEYS = 5
"""0: none; 1, 2: a section joins the inside ends of vertical edges (0, 3), (1, 2); 3, 4: the outside ones."""
VERTICAL_PAIRS = ((0, 3), (1, 2))


def ambiguous_faces(case: int) -> tuple[int, ...]:
    """The faces of `case` whose four corners alternate inside / outside."""
    out = []
    for face in range(6):
        inside = [case >> c & 1 for c in FACE_CORNERS[face]]
        if inside in ([1, 0, 1, 0], [0, 1, 0, 1]):
            out.append(face)
    return tuple(out)


def face_keys_of(case: int):
    """Every face key of `case`: each subset of its ambiguous faces joining their inside corners."""
    faces = ambiguous_faces(case)
    for bits in range(1 << len(faces)):
        yield sum(1 << f for i, f in enumerate(faces) if bits >> i & 1)


def loops(case: int, face_key: int) -> tuple[tuple[int, ...], ...]:
    """The closed loops of `case` with its ambiguous faces decided by `face_key`."""
    return _loops(case, face_key)


class _Sets:
    def __init__(self, n: int):
        self.parent = list(range(n))

    def find(self, a: int) -> int:
        while self.parent[a] != a:
            a = self.parent[a]
        return a

    def join(self, a: int, b: int) -> None:
        a, b = self.find(a), self.find(b)
        if a != b:
            self.parent[max(a, b)] = min(a, b)


def surface_regions(case: int, face_key: int) -> list[int]:
    """A region label per corner: corners joined on the cube's surface (along cell edges with no crossing,
    and across ambiguous faces by the face key's decision) share one."""
    sets = _Sets(8)
    for lo, hi in EDGE_CORNERS:
        if (case >> lo & 1) == (case >> hi & 1):
            sets.join(int(lo), int(hi))
    for face in ambiguous_faces(case):
        cycle = FACE_CORNERS[face]
        side = 1 if face_key >> face & 1 else 0  # the side whose diagonal is joined
        pair = [c for c in cycle if (case >> c & 1) == side]
        sets.join(*pair)
    return [sets.find(c) for c in range(8)]


def _loop_sides(case: int, loop: tuple[int, ...], regions: list[int]) -> tuple[int, int]:
    """The (inside, outside) surface regions a loop runs between."""
    lo, hi = (int(c) for c in EDGE_CORNERS[loop[0]])
    inside, outside = (lo, hi) if case >> lo & 1 else (hi, lo)
    return regions[inside], regions[outside]


def tunnel_corners(case: int, tunnel: int) -> tuple[int, int] | None:
    """The two corners a tunnel key joins (each vertical edge's end on the joined side), or None."""
    if tunnel == 0:
        return None
    pair = VERTICAL_PAIRS[(tunnel - 1) % 2]
    side = 1 if tunnel <= 2 else 0
    corners = []
    for edge in pair:
        ends = [c for c in (edge, edge + 4) if (case >> c & 1) == side]
        if not ends:
            return None  # that vertical edge never is on the side: no such section exists
        corners.append(ends[0])
    return corners[0], corners[1]


FIRST_CELL_VERTEX = 12
"""Triangle codes 12, 13, ... name the cell's own vertices (each the mean of a set of its edge vertices, MC33's
vertex 12), used where no triangulation on edge vertices alone keeps every new edge off the cube's faces."""
LONG_LOOP = 9
"""Loops of this many vertices or more are fanned from a cell vertex (their triangulations without one
mostly put a diagonal in a face, and there are thousands of them to try)."""


def _in_a_face(p: int, q: int) -> bool:
    return p < FIRST_CELL_VERTEX and q < FIRST_CELL_VERTEX and bool(EDGE_FACES[p] & EDGE_FACES[q])


def _on_one_face(edges) -> bool:
    return bool(frozenset.intersection(*(EDGE_FACES[e] for e in edges)))


def _key(code: int, extras):
    return code if code < FIRST_CELL_VERTEX else tuple(extras[code - FIRST_CELL_VERTEX])


@cache
def _angle(keys) -> float:
    """Smallest angle of a triangle whose corners are edge midpoints (an int) or their means (a tuple)."""
    if all(isinstance(k, int) for k in keys):
        return _triangle_min_angle(*keys)
    return smallest_angle([EDGE_MIDPOINT[k] if isinstance(k, int) else EDGE_MIDPOINT[list(k)].mean(axis=0)
                           for k in keys])


def _min_angle(triangles, extras=()) -> float:
    return min(_angle(tuple(_key(c, extras) for c in t)) for t in triangles)


def _fan(polygon, vertex: int):
    return [(polygon[i], polygon[(i + 1) % len(polygon)], vertex) for i in range(len(polygon))]


@cache
def _disk(loop: tuple[int, ...]):
    """`case_table`'s triangulation of one loop, or a fan from a cell vertex (the mean of the loop's vertices)
    where it has none.  Returns (triangles, the cell vertices' edge sets) with cell vertices numbered from
    FIRST_CELL_VERTEX."""
    if len(loop) < LONG_LOOP:
        try:
            return tuple(_triangulate(loop, _max_angle_score)), ()
        except AssertionError:
            pass
    return tuple(_fan(loop, FIRST_CELL_VERTEX)), (tuple(sorted(loop)),)


@cache
def _step_patterns(n: int, m: int) -> tuple[frozenset, ...]:
    """Which of a zipper's n + m steps walk loop `a` (n of them), leaving out those where they come all
    together (cyclically): one vertex of `b` fanned over the whole of `a`, where the tube would pinch."""
    patterns = []
    for steps in itertools.combinations(range(n + m), n):
        chosen = frozenset(steps)
        if sum(1 for s in chosen if (s - 1) % (n + m) not in chosen) > 1:
            patterns.append(chosen)
    return tuple(patterns)


def _zippers(a: tuple[int, ...], b: tuple[int, ...], prune: bool):
    """Every tube between loops `a` and `b` on their own vertices: triangles (a[i-1], a[i], b[j]) and
    (b[j], b[j+1], a[i]), walking `a` backwards and `b` forwards.  Yields (triangles, connecting edges
    (a vertex, b vertex) after each triangle); with `prune`, only those with no connecting edge in a face.
    Every zipper passes a[0]: started there, each tube is made once per way round (not once per vertex of a)."""
    n, m = len(a), len(b)
    for start_b in range(m):
        if prune and _in_a_face(a[0], b[start_b]):
            continue
        for steps in _step_patterns(n, m):
            i, j, tris, links = 0, start_b, [], []
            for s in range(n + m):
                if s in steps:
                    tris.append((a[(i - 1) % n], a[i % n], b[j % m]))
                    i -= 1
                else:
                    tris.append((b[j % m], b[(j + 1) % m], a[i % n]))
                    j += 1
                links.append((a[i % n], b[j % m]))
                if prune and _in_a_face(*links[-1]):
                    break
            else:
                yield tris, links


def _mended(tris, links):
    """A zipper whose connecting edges that lie in a cube face are taken out: the triangles between two kept
    edges form a polygon, fanned from a cell vertex of its own (the mean of its vertices).  None where fewer
    than two edges are kept (the fan would pinch) or a polygon lies in one face."""
    kept = [k for k, link in enumerate(links) if not _in_a_face(*link)]
    if len(kept) < 2:
        return None
    out, extras = [], []
    for first, last in zip(kept, kept[1:] + [kept[0] + len(tris)]):
        run = [tris[(k + 1) % len(tris)] for k in range(first, last)]
        if len(run) == 1:
            out.extend(run)
            continue
        ring = _run_polygon(run)
        if ring is None or _on_one_face(ring):
            return None
        extras.append(tuple(sorted(ring)))
        out.extend(_fan(ring, FIRST_CELL_VERTEX + len(extras) - 1))
    return out, extras


def _run_polygon(run):
    """The boundary of a strip of triangles (consecutive ones share an edge), as a cycle of vertices oriented
    as the triangles are."""
    count: dict[tuple[int, int], int] = {}
    for t in run:
        for k in range(3):
            e = (t[k], t[(k + 1) % 3])
            count[e] = count.get(e, 0) + 1
    boundary = [e for e in count if (e[1], e[0]) not in count]
    nxt = dict(boundary)
    if len(nxt) != len(boundary):
        return None  # a vertex twice on the boundary: no simple polygon
    start = min(nxt)
    cycle = [start]
    while nxt[cycle[-1]] != start and len(cycle) <= len(boundary):
        cycle.append(nxt[cycle[-1]])
    return cycle if len(cycle) == len(boundary) else None


def _tube_options(a, b):
    for tris, _ in _zippers(a, b, prune=True):
        yield tris, ()
    n, m = len(a), len(b)
    for i0 in range(n):
        for j0 in range(m):
            a0, a1, b0, b1 = a[i0], a[(i0 + 1) % n], b[j0], b[(j0 + 1) % m]
            if _in_a_face(a0, b1) or _in_a_face(a1, b0):
                continue
            c = FIRST_CELL_VERTEX
            fans = [(a[i], a[(i + 1) % n], c) for i in range(n) if i != i0]
            fans += [(b[j], b[(j + 1) % m], c) for j in range(m) if j != j0]
            fans += [(c, a0, b1), (c, b0, a1)]
            both = (tuple(sorted(a + b)),)
            if not _in_a_face(a0, b0):
                yield fans + [(a0, a1, b0), (a0, b0, b1)], both
            if not _in_a_face(a1, b1):
                yield fans + [(a0, a1, b1), (a1, b0, b1)], both


@cache
def _tube(a: tuple[int, ...], b: tuple[int, ...]):
    """The tube between two loops (each oriented with the inside on its left seen from outside), with no new
    edge in a cube face: on edge vertices where it can be, else through one cell vertex (two bridges and a
    quad), else a zipper mended with a cell vertex per run of triangles between kept edges.  The largest
    smallest angle (cell vertices at the mean of their edges' midpoints) wins.  (triangles, cell vertices)."""
    best, best_score = None, None
    for tris, extras in _tube_options(a, b):
        score = round(_min_angle(tris, extras), 9)
        if best_score is None or score > best_score:
            best, best_score = (tuple(tris), tuple(extras)), score
    if best is not None:
        return best
    for tris, links in _zippers(a, b, prune=False):
        mended = _mended(tris, links)
        if mended is None:
            continue
        tris, extras = mended
        score = (-len(extras), round(_min_angle(tris, extras), 9))
        if best_score is None or score > best_score:
            best, best_score = (tuple(tris), tuple(extras)), score
    if best is None:
        raise AssertionError(f"loops {a} and {b}: every tube puts an edge in a face")
    return best


@cache
def cell_triangles(case: int, face_key: int, tunnel: int):
    """The triangles of one (case, faces, tunnel) key, outward wound, as codes (0-11 the cell's edges,
    FIRST_CELL_VERTEX + k its k-th own vertex), and each own vertex's edges (it sits at their vertices' mean)."""
    cell_loops = loops(case, face_key)
    regions = surface_regions(case, face_key)
    tube = None
    corners = tunnel_corners(case, tunnel)
    if corners is not None and regions[corners[0]] != regions[corners[1]]:
        joined = {regions[corners[0]], regions[corners[1]]}
        inside_joined = tunnel <= 2
        # Each joined region's loop that borders a region of the other side they share.
        sides = [_loop_sides(case, loop, regions) for loop in cell_loops]
        own = lambda s: s[0] if inside_joined else s[1]  # noqa: E731
        other = lambda s: s[1] if inside_joined else s[0]  # noqa: E731
        candidates = []
        for p, q in itertools.combinations(range(len(cell_loops)), 2):
            if {own(sides[p]), own(sides[q])} == joined and other(sides[p]) == other(sides[q]):
                candidates.append((p, q))
        if len(candidates) != 1:
            raise AssertionError(f"case {case} faces {face_key} tunnel {tunnel}: tube loops {candidates}")
        tube = candidates[0]
    triangles: list[tuple[int, int, int]] = []
    extras: list[tuple[int, ...]] = []

    def add(part):
        tris, own = part
        shift = len(extras)
        triangles.extend(tuple(c if c < FIRST_CELL_VERTEX else c + shift for c in t) for t in tris)
        extras.extend(own)

    for index, loop in enumerate(cell_loops):
        if tube is None or index not in tube:
            add(_disk(loop))
    if tube is not None:
        add(_tube(cell_loops[tube[0]], cell_loops[tube[1]]))
    return tuple(triangles), tuple(extras)


KEYS = 256 * 64 * TUNNEL_KEYS
"""Table keys: case | face key << 8 | tunnel << 14."""


def table_key(case, face_key, tunnel):
    return case | face_key << 8 | tunnel << 14


@dataclass(frozen=True)
class TrilinearTable:
    """Triangles per key as codes (0-11 the cell's edges, 12 + k its own vertex k), padded with -1, and each
    own vertex's edges as a 12-bit mask (0 where the key has no such vertex)."""
    triangles: np.ndarray    # (KEYS, widest, 3) int8
    counts: np.ndarray       # (KEYS,) uint8
    cell_vertices: np.ndarray  # (KEYS, most own vertices) uint16 edge masks

    code_bits = 4  # bits per triangle code in packed_for_gpu (a class constant, not a field)

    @property
    def max_triangles(self) -> int:
        return self.triangles.shape[1]

    def packed_for_gpu(self) -> np.ndarray:
        """uint32 words for the GPU's key table (shaders/mc3_key_table.glsl): per key (256 + key) a header,
        where its list starts | its triangle count << 17 | its own vertex count << 21 (0 for a key with no
        triangles); per case (0..255) its ambiguous faces | whether any decision changes its cell (bit 6,
        `case_masks`) | the header of the key that is the case itself << 7 (so a cell no decision changes
        costs one load); then the lists: per key its own vertices' edge masks, then its triangles, codes
        c0 | c1 << 4 | c2 << 8 (code_bits apart)."""
        ambiguous, needs = case_masks()
        counts = self.counts.astype(np.int64)
        own = (self.cell_vertices > 0).sum(axis=1).astype(np.int64)
        keys = np.flatnonzero(counts)
        t, bits = self.triangles.astype(np.int64), self.code_bits
        codes = t[..., 0] | t[..., 1] << bits | t[..., 2] << 2 * bits
        lists = [np.concatenate([self.cell_vertices[key, :own[key]], codes[key, :counts[key]]]) for key in keys]
        starts = 256 + KEYS + np.concatenate([[0], np.cumsum([len(row) for row in lists])[:-1]])
        headers = np.zeros(KEYS, np.int64)
        headers[keys] = starts | counts[keys] << 17 | own[keys] << 21
        if starts[-1] + len(lists[-1]) >= 1 << 17 or own.max() >= 4:  # a header must fit 23 bits
            raise AssertionError("the packed trilinear table outgrew its 17-bit list offsets")
        cases = ambiguous | needs.astype(np.int64) << 6 | headers[:256] << 7
        return np.concatenate([cases, headers, *lists]).astype(np.uint32)


@cache
def trilinear_table() -> TrilinearTable:
    """The whole table (about a second to derive: made once per process that asks for the topology)."""
    per_key: dict[int, tuple] = {}
    for case in range(256):
        for face_key in face_keys_of(case):
            for tunnel in range(TUNNEL_KEYS):
                per_key[table_key(case, face_key, tunnel)] = cell_triangles(case, face_key, tunnel)
    width = max(len(t) for t, _ in per_key.values())
    most = max(len(e) for _, e in per_key.values())
    triangles = np.full((KEYS, width, 3), -1, dtype=np.int8)
    counts = np.zeros(KEYS, dtype=np.uint8)
    cell_vertices = np.zeros((KEYS, most), dtype=np.uint16)
    for key, (tris, extras) in per_key.items():
        counts[key] = len(tris)
        if tris:
            triangles[key, : len(tris)] = tris
        for k, edges in enumerate(extras):
            cell_vertices[key, k] = sum(1 << e for e in edges)
    return TrilinearTable(triangles, counts, cell_vertices)


@cache
def case_masks() -> tuple[np.ndarray, np.ndarray]:
    """Per case: its ambiguous faces (a 6-bit mask, int64), and whether any decision of its faces or tunnel
    changes its triangles (bool): where not, its key is the case itself and no sample need be read."""
    table = trilinear_table()
    ambiguous = np.zeros(256, np.int64)
    needs = np.zeros(256, np.bool_)
    for case in range(256):
        ambiguous[case] = sum(1 << f for f in ambiguous_faces(case))
        plain = table_key(case, 0, 0)
        for face_key in face_keys_of(case):
            for tunnel in range(TUNNEL_KEYS):
                key = table_key(case, face_key, tunnel)
                if (table.counts[key] != table.counts[plain] or (table.triangles[key] != table.triangles[plain]).any()
                        or (table.cell_vertices[key] != table.cell_vertices[plain]).any()):
                    needs[case] = True
    return ambiguous, needs

"""Marching cubes a block at a time, stitched into exactly the whole-volume mesh.

The volume's cells are cut into boxes of at most `chunks` cells per axis.  Each box is
read with a halo of one sample on every side (its last cells' far corners, and the
neighbours the central-difference normals need), extracted by the GPU Extractor, and
only the triangles of the box's own cells are kept.  Every vertex of the default topology
lies on a grid edge (the trilinear topology's own vertices: below): its GLOBAL edge id
(owning sample's flat index x 3 + axis) names it, so a vertex that two boxes both make
(on their shared face) is merged into one, and the stitched mesh is watertight across
the seams.  Vertex attributes are placed by the numpy reference on the haloed block in
whole-volume coordinates (reference.vertex_positions with `origin`), which the GPU
matches byte for byte; normals and values are the GPU's (the halo gives them the whole
volume's neighbours); vertices and triangles are then put in the order a whole-volume
extraction gives.  So the result equals `marching_cubes(volume)` array for array, not
only up to order.

topology="trilinear" too: a cell's key (case, faces, tunnel) depends on its eight samples alone (a face's
decision on its four: neighbours agree), so the haloed block decides each cell as the whole volume does.
A tube cell's own vertices (not on a grid edge) are named by their cell and their rank in it (the keys
of the block's cells that can have one are decided again in numpy, `own_vertex_cells`), made again
in the merge from the merged edge vertices in the reference's float32 arithmetic
(trilinear.mean_vertices), and put after every edge vertex in the whole volume's cell order, as
`isoscope.cpu.trilinear` puts them.

Memory: one block at a time, (c + 3)^3 samples for chunks of c cells: the block, its
float32 copy and inside mask in numpy, the same on the GPU (texture + scratch of about
0.5 byte a voxel) - about 10 bytes a voxel of the block for a float32 source - plus the
mesh made so far (about 120 bytes a triangle at the merge's peak - 4.7 GiB for 40.5 M triangles
at 1024^3 - where the mesh itself is about 26: 12 for its triangle, 14 for its half of a vertex).  The
volume itself is never in memory: a memory-mapped file or a Zarr array is read a
block at a time (lazy_arrays.read_block).
"""
from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass
from functools import cache

import numpy as np

from .. import validation
from ..core.lazy_arrays import read_block
from ..core.trilinear_table import topology_problem
from ..cpu.cubes import brick_order_key, vertex_positions
from ..errors import InputError
from ..gpu.limits import GPULimitError
from ..gpu.mesh import empty_mesh

DEFAULT_CHUNK = 128  # cells per axis: a 131^3 float32 block is 8.6 MiB


@dataclass
class ChunkMesh:
    """One box's share of the mesh, named by global edge ids (mergeable in any order)."""
    edge_ids: np.ndarray  # (V,) int64: global edge id of each vertex
    verts: np.ndarray  # (V, 3) float32, whole-volume positions
    normals: np.ndarray  # (V, 3) float32
    values: np.ndarray  # (V,) float32
    faces: np.ndarray  # (T, 3) int32 indices into this box's vertices
    cell_keys: np.ndarray  # (T,) int64 whole-volume order of each triangle's cell (cell_key)
    # topology="trilinear": the own vertices of the box's cells, after its edge vertices (faces count on)
    own_keys: np.ndarray | None = None  # (O,) int64 whole-volume order: cell_key * 4 + rank in the cell
    own_members: np.ndarray | None = None  # (O, 12) int64 global edge ids it is the mean of, in edge order, -1 after


def cell_key(cells: np.ndarray, shape) -> np.ndarray:
    """The order reference.py (and the GPU) puts cells in: (brick, word in brick, k), as one int64."""
    return brick_order_key(cells, shape) * shape[2] + cells[:, 2]


def vertex_key(owners: np.ndarray, axes: np.ndarray, shape) -> np.ndarray:
    """The order of vertices: (brick, word in brick, axis, k), as one int64."""
    return (brick_order_key(owners, shape) * 3 + axes) * shape[2] + owners[:, 2]


def as_chunks(chunks, shape) -> tuple[int, int, int]:
    """Cells per box along each axis, from N or (a, b, c); a one-line ValueError otherwise."""
    sizes = (chunks,) * 3 if np.isscalar(chunks) else tuple(chunks)
    if len(sizes) != 3 or not all(isinstance(c, (int, np.integer)) and not isinstance(c, bool) and c >= 1
                                  for c in sizes):
        raise InputError(f"chunks must be a whole number of cells (1 or more) or three of them, got {chunks!r}")
    return tuple(min(int(c), n - 1) for c, n in zip(sizes, shape))


def chunk_boxes(shape, chunks) -> list[tuple[tuple[int, ...], tuple[int, ...]]]:
    """(first cell, end cell) of every box, in C order."""
    sizes = as_chunks(chunks, shape)
    starts = [range(0, n - 1, c) for n, c in zip(shape, sizes)]
    return [(start, tuple(min(a + c, n - 1) for a, c, n in zip(start, sizes, shape)))
            for start in itertools.product(*starts)]


def value_range(source, chunks) -> tuple[float, float]:
    """min and max of a lazy volume, read a box at a time."""
    lo, hi = np.inf, -np.inf
    for start, stop in chunk_boxes(source.shape, chunks):
        block = read_block(source, tuple(slice(a, b + 1) for a, b in zip(start, stop)))
        lo, hi = min(lo, float(block.min())), max(hi, float(block.max()))
    return lo, hi


def edges_of(verts: np.ndarray, spacing) -> tuple[np.ndarray, np.ndarray]:
    """(owning grid point (V, 3), axis (V,)) of vertices that lie on grid edges.

    A vertex is at point + t * axis with t in [EDGE_MARGIN, 1 - EDGE_MARGIN] (1/256: ties
    are pushed off the grid point, see reference.py), so exactly one coordinate is 1/256 or
    more from a whole number: that is the edge's axis, and its floor the owner's coordinate.
    Block-local coordinates are small, so float32 rounding is far below the margin."""
    index = verts.astype(np.float64) / np.asarray(spacing, np.float64)
    nearest = np.rint(index)
    axes = np.argmax(np.abs(index - nearest), axis=1)
    rows = np.arange(len(index))
    nearest[rows, axes] = np.floor(index[rows, axes])
    return nearest.astype(np.int64), axes.astype(np.int64)


def extract_box(source, box, level: float, spacing, descent: bool, ctx=None, shape=None,
                backend: str = "gpu", topology: str = "montani") -> ChunkMesh | None:
    """The mesh of one box's cells (None when the level does not cross it), with a fresh Extractor
    in `ctx` (its compiled programs are cached per context, so boxes after the first compile nothing),
    or with backend "cpu" / "numpy" a CpuExtractor (the same mesh; no GL).  `topology` "trilinear": the
    trilinear interpolant's (a box whose mesh the GPU cannot hold in one storage block is made on the CPU)."""
    shape = shape or source.shape
    start, stop = box
    origin = np.array([max(a - 1, 0) for a in start], np.int64)
    block = read_block(source, tuple(slice(o, min(b + 2, n)) for o, b, n in zip(origin, stop, shape)))
    checked = validation.check_volume(block, "volume", where=lambda index: validation._at_index(np.add(index, origin)))
    lo, hi = checked.value_range
    if not np.float32(lo) <= np.float32(level) <= np.float32(hi):
        # Every sample on one side: no edge of this box crosses the level.  Compared in float32, as the
        # extractors compare: a float64 (or large integer) sample just below the level that float32 rounds
        # onto it is inside for them, so a box of such samples has a surface (rounding keeps order).
        return None
    # The box's extractor holds the level to the box's own range in float64: the nearest level inside it is the
    # same float32 level (the float32 test above passed), so the same mesh.
    box_level = min(max(level, lo), hi)
    trilinear = topology == "trilinear"
    try:
        verts, faces, gpu_normals, gpu_values = _box_mesh(checked, box_level, spacing, descent, ctx, backend,
                                                          trilinear)
    except GPULimitError:
        if not trilinear:
            raise
        # The topology's own vertices need the box's mesh in one storage block: the CPU makes the same mesh.
        verts, faces, gpu_normals, gpu_values = _box_mesh(checked, box_level, spacing, descent, ctx, "cpu",
                                                          trilinear)
    if not len(faces):
        return None
    field = checked.samples.astype(np.float32) if descent else -checked.samples.astype(np.float32)  # its own order
    lvl = np.float32(level if descent else -level)
    own_cells, own_ranks = own_vertex_cells(field, lvl) if trilinear else (np.zeros((0, 3), np.int64), None)
    n_edge = len(verts) - len(own_cells)   # the own vertices come after every edge vertex
    if trilinear and n_edge != crossing_edge_count(field, lvl):
        raise AssertionError(f"the box's mesh has {len(verts) - n_edge} vertices off the grid edges, not the "
                             f"{len(own_cells)} its cells' keys give: the extractors and chunked.py disagree")
    points, axes = edges_of(verts[:n_edge], spacing)
    # A triangle's cell: per axis the least owner coordinate of its corners (no triangle of either table
    # lies in a cell's far face, tests/big/test_chunked*.py check it); with an own vertex, that vertex's.
    if not len(own_cells):   # every vertex on a grid edge (the default topology's mesh, always)
        cells = points[faces].min(axis=1) + origin
        keep = np.all((cells >= start) & (cells < stop), axis=1)
        faces, cells = faces[keep], cells[keep]
        used, corners = np.unique(faces, return_inverse=True)
        corners = corners.reshape(-1, 3).astype(np.int32)
    else:
        cells = points[np.minimum(faces, n_edge - 1)].min(axis=1)
        with_own = faces.max(axis=1) >= n_edge
        cells[with_own] = own_cells[faces[with_own].max(axis=1) - n_edge]
        cells += origin
        keep = np.all((cells >= start) & (cells < stop), axis=1)
        faces, cells = faces[keep], cells[keep]
        own_kept = np.flatnonzero(np.all((own_cells + origin >= start) & (own_cells + origin < stop), axis=1))
        used = np.unique(faces[faces < n_edge])
        rows = np.full(len(verts), -1, np.int64)   # a box row (its used edge vertices, then its own) per vertex
        rows[used] = np.arange(len(used))
        rows[n_edge + own_kept] = len(used) + np.arange(len(own_kept))
        corners = rows[faces].astype(np.int32)
    positions = vertex_positions(field, lvl, points[used], axes[used], np.asarray(spacing, np.float64), origin)
    edge_ids = np.ravel_multi_index((points[used] + origin).T, shape) * 3 + axes[used]
    mesh = ChunkMesh(edge_ids, positions, gpu_normals[used], gpu_values[used], corners, cell_key(cells, shape))
    if len(own_cells):
        mesh.own_keys, mesh.own_members = own_vertex_names(field, lvl, own_cells[own_kept], own_ranks[own_kept],
                                                           origin, shape)
    return mesh


def _box_mesh(checked, level, spacing, descent, ctx, backend, trilinear):
    """The haloed block's mesh (verts, faces, normals, values) from one extractor on `backend`."""
    direction = "descent" if descent else "ascent"
    topology = "trilinear" if trilinear else "montani"
    if backend in ("cpu", "numpy"):
        from ..cpu.extractor import CpuExtractor
        extractor = CpuExtractor(checked, spacing=spacing, gradient_direction=direction, backend=backend,
                                 topology=topology)
    else:
        from ..gpu.cubes import Extractor
        from ..gpu.trilinear import TrilinearExtractor
        extractor = (TrilinearExtractor if trilinear else Extractor)(checked, spacing=spacing,
                                                                     gradient_direction=direction, ctx=ctx)
    try:
        extractor.extract(level)
        return extractor.read_mesh()
    finally:
        extractor.release()


def own_vertex_cells(field: np.ndarray, lvl) -> tuple[np.ndarray, np.ndarray]:
    """(cell (O, 3), rank within the cell (O,)) of every own vertex of the trilinear topology's mesh of the
    block `field` (the signed field), in the order its extractors write them: cells in (brick, word, k)
    order, a cell's in the table's.  Only the cells whose case can have one are decided again."""
    from ..cpu.cubes import cube_cases, inside_mask
    from ..cpu.trilinear import keys_of_cells
    table, possible = _own_vertex_tables()
    cells = np.argwhere(possible[cube_cases(inside_mask(field, lvl))])
    counts = (table.cell_vertices[keys_of_cells(field, lvl, cells)] > 0).sum(axis=1)
    cells, counts = cells[counts > 0], counts[counts > 0]
    order = np.argsort(cell_key(cells, field.shape), kind="stable")
    cells, counts = cells[order], counts[order]
    ranks = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    return np.repeat(cells, counts, axis=0), ranks


def crossing_edge_count(field: np.ndarray, lvl) -> int:
    """How many grid edges of the signed field cross the level: its mesh's edge vertices."""
    from ..cpu.cubes import crossing_edges, inside_mask
    return sum(int(np.count_nonzero(mask)) for mask in crossing_edges(inside_mask(field, lvl)))


def own_vertex_names(field, lvl, cells, ranks, origin, shape) -> tuple[np.ndarray, np.ndarray]:
    """(whole-volume order key, member edge ids (O, 12) padded with -1) of own vertices of block cells `cells`."""
    from ..cpu.cubes import cell_edge_ids
    from ..cpu.trilinear import keys_of_cells
    table, _ = _own_vertex_tables()
    masks = table.cell_vertices[keys_of_cells(field, lvl, cells), ranks].astype(np.int64)  # own slots come first
    whole = cells + origin
    edges = np.arange(12)
    ids = cell_edge_ids(whole[:, None, :], edges[None, :], shape)
    member = (masks[:, None] >> edges & 1).astype(bool)
    slot = np.argsort(~member, axis=1, kind="stable")   # the members to the left, in edge order
    members = np.where(np.take_along_axis(member, slot, axis=1), np.take_along_axis(ids, slot, axis=1), -1)
    return cell_key(whole, shape) * 4 + ranks, members


@cache
def _own_vertex_tables():
    """The trilinear table, and per case whether any of its keys has an own vertex (made once: two calls a box)."""
    from ..core.trilinear_table import trilinear_table
    table = trilinear_table()
    possible = np.zeros(256, bool)
    possible[np.flatnonzero(table.cell_vertices[:, 0] > 0) & 255] = True
    return table, possible


def merge(parts: list[ChunkMesh | None], shape):
    """verts, faces, normals, values of the boxes' meshes joined at shared edges, in whole-volume order: the
    edge vertices by edge, then the trilinear topology's own vertices by cell (each made by its cell's box).

    Consumes `parts`: each box's arrays are dropped once copied, to keep the peak near two copies of the mesh."""
    parts = [p for p in parts if p is not None]
    if not parts:
        return empty_mesh()
    own_counts = [0 if p.own_keys is None else len(p.own_keys) for p in parts]
    edge_counts = [len(p.edge_ids) for p in parts]
    first_row = np.cumsum([0] + [e + o for e, o in zip(edge_counts, own_counts)])
    index = np.int32 if first_row[-1] < 2**31 else np.int64  # half the memory for the faces, as a rule
    columns = {}
    for name in ("faces", "cell_keys", "edge_ids", "verts", "normals", "values"):
        columns[name] = np.concatenate([getattr(p, name) + index(offset) if name == "faces" else getattr(p, name)
                                        for p, offset in zip(parts, first_row)])
        for p in parts:
            setattr(p, name, None)
    own_keys = np.concatenate([p.own_keys for p in parts if p.own_keys is not None] or [np.zeros(0, np.int64)])
    members = np.concatenate([p.own_members for p in parts if p.own_members is not None]
                             or [np.zeros((0, 12), np.int64)])
    unique, first, inverse = np.unique(columns.pop("edge_ids"), return_index=True, return_inverse=True)
    owners = np.stack(np.unravel_index(unique // 3, shape), axis=1)
    order = np.argsort(vertex_key(owners, unique % 3, shape))
    del owners
    index_of = np.empty(len(unique), index)
    index_of[order] = np.arange(len(unique), dtype=index)
    remap = index_of[inverse.reshape(-1)]  # each box's vertex -> its place in the merged mesh
    del inverse
    verts, normals, values = (columns.pop(name)[first[order]] for name in ("verts", "normals", "values"))
    if len(own_keys):
        by_cell = np.argsort(own_keys, kind="stable")
        own_place = np.empty(len(own_keys), index)
        own_place[by_cell] = len(unique) + np.arange(len(own_keys), dtype=index)
        edge_row = np.concatenate([np.repeat([True, False], [e, o]) for e, o in zip(edge_counts, own_counts)])
        rows = np.empty(len(edge_row), index)
        rows[edge_row], rows[~edge_row] = remap, own_place
        remap = rows
        members = members[by_cell]
        taken = members >= 0
        members[taken] = index_of[np.searchsorted(unique, members[taken])]
        from ..cpu.trilinear import mean_vertices
        own = mean_vertices(verts, normals, values, members)
        verts, normals, values = (np.concatenate([a, b]) for a, b in zip((verts, normals, values), own))
    del index_of
    # Within a cell the table's order: each cell lies in one box, whose triangles keep their order.
    faces = remap[columns.pop("faces")][np.argsort(columns.pop("cell_keys"), kind="stable")]
    return verts, faces.astype(np.int32, copy=False), normals, values


def marching_cubes_chunked(source, level: float, spacing=(1.0, 1.0, 1.0), descent: bool = True,
                           chunks=DEFAULT_CHUNK, ctx=None, progress: Callable[[float, str], None] | None = None,
                           backend: str = "auto", topology: str = "montani"):
    """The whole-volume mesh of `source` (an array, memory map or Zarr array), a box at a time in one
    GL context (or with backend "cpu" / "numpy", on the CPU; "auto": gpu.context's one_shot_backend),
    with the `topology` of ambiguous cells.  `level` must already be checked against the volume's range."""
    problem = topology_problem(topology)
    if problem is not None:
        raise InputError(problem)
    if backend == "auto":
        from ..gpu.context import one_shot_backend
        backend = one_shot_backend()
    if backend == "gpu":
        from ..gpu.context import current_or_standalone
        ctx = ctx or current_or_standalone()
    boxes = chunk_boxes(source.shape, chunks)
    parts = []
    for done, box in enumerate(boxes, 1):
        parts.append(extract_box(source, box, level, spacing, descent, ctx, backend=backend, topology=topology))
        if progress is not None:
            progress(done / len(boxes), f"extracting chunk {done}/{len(boxes)}")
    return merge(parts, source.shape)

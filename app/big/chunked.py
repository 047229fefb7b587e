"""Marching cubes a block at a time, stitched into exactly the whole-volume mesh.

The volume's cells are cut into boxes of at most `chunks` cells per axis.  Each box is
read with a halo of one sample on every side (its last cells' far corners, and the
neighbours the central-difference normals need), extracted by the GPU Extractor, and
only the triangles of the box's own cells are kept.  Every vertex lies on a grid edge:
its GLOBAL edge id (owning sample's flat index x 3 + axis) names it, so a vertex that
two boxes both make (on their shared face) is merged into one, and the stitched mesh is
watertight across the seams.  Vertex attributes are placed by the numpy reference on
the haloed block in whole-volume coordinates (reference.vertex_positions with `origin`),
which the GPU matches byte for byte; normals and values are the GPU's (the halo gives
them the whole volume's neighbours); vertices and triangles are then put in the order
a whole-volume extraction gives.  So the result equals `marching_cubes(volume)` array
for array, not only up to order.

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

import numpy as np

from .. import validation
from ..core.lazy_arrays import read_block
from ..cpu.cubes import brick_order_key, vertex_positions
from ..errors import InputError
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
                backend: str = "gpu") -> ChunkMesh | None:
    """The mesh of one box's cells (None when the level does not cross it), with a fresh Extractor
    in `ctx` (its compiled programs are cached per context, so boxes after the first compile nothing),
    or with backend "cpu" / "numpy" a CpuExtractor (the same mesh; no GL)."""
    shape = shape or source.shape
    start, stop = box
    origin = np.array([max(a - 1, 0) for a in start], np.int64)
    block = read_block(source, tuple(slice(o, min(b + 2, n)) for o, b, n in zip(origin, stop, shape)))
    checked = validation.check_volume(block, "volume", where=lambda index: validation._at_index(np.add(index, origin)))
    lo, hi = checked.value_range
    if not lo <= level <= hi:
        return None  # every sample on one side: no edge of this box crosses the level
    direction = "descent" if descent else "ascent"
    if backend in ("cpu", "numpy"):
        from ..cpu.extractor import CpuExtractor
        extractor = CpuExtractor(checked, spacing=spacing, gradient_direction=direction, backend=backend)
    else:
        from ..gpu.cubes import Extractor
        extractor = Extractor(checked, spacing=spacing, gradient_direction=direction, ctx=ctx)
    try:
        extractor.extract(level)
        verts, faces, gpu_normals, gpu_values = extractor.read_mesh()
    finally:
        extractor.release()
    if not len(faces):
        return None
    points, axes = edges_of(verts, spacing)
    # A triangle's cell: per axis the least owner coordinate of its corners (no triangle of the
    # table lies in a cell's far face, tests/test_chunked.py checks it).
    cells = points[faces].min(axis=1) + origin
    keep = np.all((cells >= start) & (cells < stop), axis=1)
    faces, cells = faces[keep], cells[keep]
    used, corners = np.unique(faces, return_inverse=True)
    field = checked.samples.astype(np.float32) if descent else -checked.samples.astype(np.float32)  # its own order
    lvl = np.float32(level if descent else -level)
    positions = vertex_positions(field, lvl, points[used], axes[used], np.asarray(spacing, np.float64), origin)
    edge_ids = np.ravel_multi_index((points[used] + origin).T, shape) * 3 + axes[used]
    return ChunkMesh(edge_ids, positions, gpu_normals[used], gpu_values[used],
                     corners.reshape(-1, 3).astype(np.int32), cell_key(cells, shape))


def merge(parts: list[ChunkMesh | None], shape):
    """verts, faces, normals, values of the boxes' meshes joined at shared edges, in whole-volume order.

    Consumes `parts`: each box's arrays are dropped once copied, to keep the peak near two copies of the mesh."""
    parts = [p for p in parts if p is not None]
    if not parts:
        return empty_mesh()
    first_vertex = np.cumsum([0] + [len(p.edge_ids) for p in parts])
    index = np.int32 if first_vertex[-1] < 2**31 else np.int64  # half the memory for the faces, as a rule
    columns = {}
    for name in ("faces", "cell_keys", "edge_ids", "verts", "normals", "values"):
        columns[name] = np.concatenate([getattr(p, name) + index(offset) if name == "faces" else getattr(p, name)
                                        for p, offset in zip(parts, first_vertex)])
        for p in parts:
            setattr(p, name, None)
    unique, first, inverse = np.unique(columns.pop("edge_ids"), return_index=True, return_inverse=True)
    owners = np.stack(np.unravel_index(unique // 3, shape), axis=1)
    order = np.argsort(vertex_key(owners, unique % 3, shape))
    del owners
    index_of = np.empty(len(unique), index)
    index_of[order] = np.arange(len(unique), dtype=index)
    remap = index_of[inverse.reshape(-1)]  # each box's vertex -> its place in the merged mesh
    del inverse, index_of
    verts, normals, values = (columns.pop(name)[first[order]] for name in ("verts", "normals", "values"))
    # Within a cell the table's order: each cell lies in one box, whose triangles keep their order.
    faces = remap[columns.pop("faces")][np.argsort(columns.pop("cell_keys"), kind="stable")]
    return verts, faces.astype(np.int32, copy=False), normals, values


def marching_cubes_chunked(source, level: float, spacing=(1.0, 1.0, 1.0), descent: bool = True,
                           chunks=DEFAULT_CHUNK, ctx=None, progress: Callable[[float, str], None] | None = None,
                           backend: str = "auto"):
    """The whole-volume mesh of `source` (an array, memory map or Zarr array), a box at a time in one
    GL context (or with backend "cpu" / "numpy", on the CPU; "auto": gpu.context's one_shot_backend).
    `level` must already be checked against the volume's range."""
    if backend == "auto":
        from ..gpu.context import one_shot_backend
        backend = one_shot_backend()
    if backend == "gpu":
        from ..gpu.context import current_or_standalone
        ctx = ctx or current_or_standalone()
    boxes = chunk_boxes(source.shape, chunks)
    parts = []
    for done, box in enumerate(boxes, 1):
        parts.append(extract_box(source, box, level, spacing, descent, ctx, backend=backend))
        if progress is not None:
            progress(done / len(boxes), f"extracting chunk {done}/{len(boxes)}")
    return merge(parts, source.shape)

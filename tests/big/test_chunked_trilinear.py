"""topology="trilinear" a box at a time (isoscope.big.chunked): the stitched mesh IS the whole-volume trilinear
mesh, its cells' own vertices included, on every backend, in Python, `export --chunk`, `measure` of a Zarr
store and on dask workers."""
from __future__ import annotations

import json

import numpy as np
import pytest
import trimesh
import zarr
from support.command import isoscope_here
from support.mesh_checks import assert_closed_manifold, sign_changing_edges
from support.trilinear_cases import closed_noise

import isoscope
from isoscope.api import outward_marching_cubes
from isoscope.core.case_table import EDGE_ORIGIN
from isoscope.core.trilinear_table import FIRST_CELL_VERTEX, trilinear_table

SPACING = (1.0, 0.7, 1.3)


def tubes(seed: int = 3) -> np.ndarray:
    """Random normal noise: ambiguous cells everywhere, tubes with vertices of their own among them."""
    return np.random.default_rng(seed).standard_normal((23, 19, 30)).astype(np.float32)


def own_vertices(volume, level, mesh, direction) -> int:
    """How many of `mesh`'s vertices lie on no grid edge (the trilinear topology's own vertices)."""
    return len(mesh[0]) - sign_changing_edges(volume, level, descent=direction == "descent")


def assert_same_mesh(got, expected, normals_atol=0.0):
    """The same arrays in the same order: faces, positions and values bit for bit, normals as asked."""
    for name, a, b in zip(("verts", "faces", "normals", "values"), got, expected):
        assert a.dtype == b.dtype and a.shape == b.shape, name
        if name == "normals" and normals_atol:
            np.testing.assert_allclose(a, b, rtol=0, atol=normals_atol, err_msg=name)
        else:
            np.testing.assert_array_equal(a, b, err_msg=name)


@pytest.mark.parametrize("backend", ["cpu", "numpy"])
@pytest.mark.parametrize("direction", ["descent", "ascent"])
@pytest.mark.parametrize("field, level", [(closed_noise(7, 20), 0.0), (tubes(), 0.1)], ids=["closed", "tubes"])
def test_chunked_trilinear_mesh_equals_the_whole_volume_mesh(backend, direction, field, level):
    whole = outward_marching_cubes(field, level, spacing=SPACING, gradient_direction=direction, backend="numpy",
                                   topology="trilinear")
    assert own_vertices(field, level, whole, direction) > 50   # the merge has cells' own vertices to place
    for chunks in (3, 5, (7, 4, 6)):   # seams through many cells, tubes cut at box faces
        stitched = outward_marching_cubes(field, level, spacing=SPACING, gradient_direction=direction,
                                          backend=backend, topology="trilinear", chunks=chunks)
        assert_same_mesh(stitched, whole)
    if field[0, 0, 0] == -1:   # closed noise: the stitched tubes close too
        assert_closed_manifold(stitched[1])


def test_chunked_trilinear_with_scikit_images_winding_and_values():
    field = tubes(4)
    whole = isoscope.marching_cubes(field, 0.0, backend="numpy", topology="trilinear")
    assert_same_mesh(isoscope.marching_cubes(field, 0.0, backend="cpu", topology="trilinear", chunks=6), whole)


def test_chunked_trilinear_differs_from_the_chunked_default():
    """The topology reaches the boxes: on noise, a chunked montani mesh is another mesh."""
    field = tubes(5)
    trilinear = outward_marching_cubes(field, 0.0, backend="cpu", topology="trilinear", chunks=7)
    montani = outward_marching_cubes(field, 0.0, backend="cpu", chunks=7)
    assert len(trilinear[0]) > len(montani[0]) and len(trilinear[1]) != len(montani[1])


@pytest.mark.parametrize("direction", ["descent", "ascent"])
def test_chunked_trilinear_on_the_gpu_equals_its_whole_volume_mesh(gl_ctx, direction):
    field = tubes(6)
    whole = outward_marching_cubes(field, 0.1, spacing=SPACING, gradient_direction=direction, backend="gpu",
                                   topology="trilinear")
    assert own_vertices(field, 0.1, whole, direction) > 50
    for chunks in (5, (7, 4, 6)):
        stitched = outward_marching_cubes(field, 0.1, spacing=SPACING, gradient_direction=direction, backend="gpu",
                                          topology="trilinear", chunks=chunks)
        assert_same_mesh(stitched, whole)


def test_a_box_the_gpu_cannot_hold_is_made_on_the_cpu(gl_ctx, monkeypatch):
    """A GPU whose storage blocks cannot hold a box's trilinear mesh (the small block imitates one, as
    tests/gpu/test_gpu_trilinear.py does): that box is extracted on the CPU, the stitched mesh is still the
    whole volume's (normals within float32 rounding: the two backends may round the last bit apart)."""
    from isoscope.errors import IsoscopeError
    from isoscope.gpu.limits import GpuLimits
    field = np.random.default_rng(2).standard_normal((24, 24, 40)).astype(np.float32)
    real = GpuLimits.of(gl_ctx)
    monkeypatch.setattr(GpuLimits, "of", classmethod(lambda cls, ctx: cls(real.max_3d_texture_size,
                                                                           real.max_texture_size, 128 << 10)))
    with pytest.raises(IsoscopeError, match="backend='cpu'"):
        outward_marching_cubes(field, 0.0, backend="gpu", topology="trilinear")   # the limit bites
    # boxes of 12 cells along axis 2: the first three outgrow the block, the last (3 cells) fits it
    from isoscope.big import chunked
    backends, real_box_mesh = [], chunked._box_mesh

    def box_mesh(*args):   # the real function, its backend noted: which boxes the CPU made
        backends.append(args[5])
        return real_box_mesh(*args)
    monkeypatch.setattr(chunked, "_box_mesh", box_mesh)
    stitched = outward_marching_cubes(field, 0.0, backend="gpu", topology="trilinear", chunks=(24, 24, 12))
    assert backends == ["gpu", "cpu"] * 3 + ["gpu"]
    assert_same_mesh(stitched, outward_marching_cubes(field, 0.0, backend="cpu", topology="trilinear"),
                     normals_atol=1e-6)


def test_no_edge_triangle_of_the_trilinear_table_lies_in_a_cells_far_face():
    """chunked.py finds the cell of a triangle with no own vertex as its corners' least owner coordinates
    (that of one with an own vertex is the vertex's): no triangle of edge vertices lies in a face x_d = 1."""
    table = trilinear_table()
    for key in np.flatnonzero(table.counts):
        for codes in table.triangles[key, :table.counts[key]]:
            if (codes < FIRST_CELL_VERTEX).all():
                assert not (EDGE_ORIGIN[codes] == 1).all(axis=0).any(), (key, codes)


def test_export_chunk_writes_the_unchunked_trilinear_file(tmp_path):
    field = tubes(7)
    np.save(tmp_path / "noise.npy", field)
    for name, extra in (("whole.ply", []), ("chunked.ply", ["--chunk", "4"])):
        done = isoscope_here("export", tmp_path / "noise.npy", "--iso", "0", "--topology", "trilinear",
                             "--out", tmp_path / name, *extra)
        assert done.returncode == 0, done.stderr
    whole, chunked = (trimesh.load(tmp_path / name, process=False) for name in ("whole.ply", "chunked.ply"))
    verts, faces, _, _ = outward_marching_cubes(field, 0.0, backend="numpy", topology="trilinear")
    assert len(verts) > sign_changing_edges(field, 0.0) and len(chunked.faces) == len(faces)
    np.testing.assert_array_equal(chunked.faces, whole.faces)
    np.testing.assert_array_equal(chunked.vertices, whole.vertices)
    np.testing.assert_array_equal(chunked.vertex_normals, whole.vertex_normals)


def test_measure_of_a_zarr_store_counts_what_the_in_memory_volume_has(tmp_path):
    """A Zarr store is measured a box at a time (128 cells: two boxes along its long axis): with --topology
    trilinear every number is the in-memory volume's, pieces, Euler characteristic and genus included."""
    field = np.full((150, 14, 14), -1.0, np.float32)   # closed noise, longer than one box
    field[1:-1, 1:-1, 1:-1] = np.random.default_rng(8).standard_normal((148, 12, 12))
    np.save(tmp_path / "noise.npy", field)
    zarr.create_array(str(tmp_path / "noise.zarr"), shape=field.shape, chunks=(16, 16, 16), dtype="f4")[:] = field
    rows = {}
    for name in ("noise.npy", "noise.zarr"):
        done = isoscope_here("measure", tmp_path / name, "--iso", "0", "--json", "--topology", "trilinear")
        assert done.returncode == 0, done.stderr
        (rows[name],) = json.loads(done.stdout)
    in_memory, chunked = rows["noise.npy"], rows["noise.zarr"]
    assert in_memory["components"] > 10 and in_memory["genus"] is not None
    for key in ("components", "euler", "genus", "cavities", "open_edges", "area_mm2", "volume_ml"):
        assert chunked[key] == in_memory[key], key
    montani = json.loads(isoscope_here("measure", tmp_path / "noise.zarr", "--iso", "0", "--json").stdout)[0]
    assert (montani["components"], montani["euler"]) != (chunked["components"], chunked["euler"])


def test_dask_workers_make_the_whole_volume_trilinear_mesh(tmp_path):
    """The dask path is the same machinery: a local cluster of 2 workers stitches the one-process mesh."""
    pytest.importorskip("dask.distributed")
    from isoscope.big.cluster import marching_cubes_on_cluster
    field = closed_noise(5, 20)
    zarr.create_array(str(tmp_path / "v.zarr"), shape=field.shape, chunks=(8, 8, 8), dtype="f4")[:] = field
    source = zarr.open(str(tmp_path / "v.zarr"), mode="r")
    mesh = marching_cubes_on_cluster(source, 0.0, (1.0, 1.0, 1.0), True, (7, 7, 7), workers=2, backend="cpu",
                                     topology="trilinear")
    assert_same_mesh(mesh, outward_marching_cubes(field, 0.0, backend="numpy", topology="trilinear"))

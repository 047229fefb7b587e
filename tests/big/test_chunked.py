"""Chunked extraction (isoscope.big.chunked): the stitched mesh IS the whole-volume mesh, in bounded memory."""
from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
from support.mesh_checks import assert_closed_manifold, sign_changing_edges

import isoscope
from isoscope.big.chunked import chunk_boxes
from isoscope.core.case_table import EDGE_ORIGIN, montani_table

RNG = np.random.default_rng(12)


def smooth_noise(shape):
    from scipy.ndimage import gaussian_filter
    return gaussian_filter(RNG.normal(size=shape), 2).astype(np.float32)


@pytest.mark.parametrize("chunks", [(16, 20, 33), 7, 500])
@pytest.mark.parametrize("direction", ["descent", "ascent"])
def test_chunked_mesh_equals_the_whole_volume_mesh(gl_ctx, chunks, direction):
    volume = smooth_noise((50, 41, 70))
    whole = isoscope.marching_cubes(volume, 0.0, spacing=(1, 0.7, 1.3), gradient_direction=direction, backend="gpu")
    stitched = isoscope.marching_cubes(volume, 0.0, spacing=(1, 0.7, 1.3), gradient_direction=direction,
                                       chunks=chunks, backend="gpu")
    for got, expected in zip(stitched, whole):  # same arrays, same order: not only the same set
        np.testing.assert_array_equal(got, expected)


def test_exact_ties_on_chunk_seams(gl_ctx):
    """Integer data with many samples equal to the level: tie vertices sit 1/256 from a grid point,
    on the seams too, and are still named by the right edge."""
    volume = np.round(smooth_noise((40, 40, 40)) * 20).astype(np.int16)
    assert np.count_nonzero(volume == 0) > 1000
    whole = isoscope.marching_cubes(volume, 0, backend="gpu")
    stitched = isoscope.marching_cubes(volume, 0, chunks=9)
    for got, expected in zip(stitched, whole):
        np.testing.assert_array_equal(got, expected)


def test_stitched_sphere_is_watertight(gl_ctx, sphere_sdf):
    field, _, _ = sphere_sdf
    verts, faces, _, _ = isoscope.marching_cubes(field, 0.0, gradient_direction="ascent", chunks=(13, 17, 30))
    assert_closed_manifold(faces)
    assert len(verts) == sign_changing_edges(field, 0.0, descent=False)


def test_no_triangle_of_the_table_lies_in_a_cells_far_face():
    """chunked.py finds a triangle's cell as its corners' least owner coordinates: that needs no
    triangle with all three corners on the face x_d = 1 of its cell."""
    table = montani_table()
    for case in range(256):
        for edges in table.triangles[case, :table.counts[case]]:
            assert not (EDGE_ORIGIN[edges] == 1).all(axis=0).any(), (case, edges)


def test_boxes_cover_every_cell_once():
    boxes = chunk_boxes((10, 7, 5), 3)
    covered = np.zeros((9, 6, 4), int)
    for start, stop in boxes:
        covered[tuple(slice(a, b) for a, b in zip(start, stop))] += 1
    assert (covered == 1).all()


@pytest.mark.parametrize("chunks", [0, (4, 4), 2.5, True])
@pytest.mark.gl
def test_bad_chunks_are_one_line_errors(chunks):
    with pytest.raises(ValueError, match="chunks must be"):
        isoscope.marching_cubes(np.zeros((4, 4, 4), np.float32) + np.arange(4), 1.5, chunks=chunks)


PEAK_SCRIPT = r"""
import json, resource, sys
import numpy as np
import isoscope
source = np.load(sys.argv[1], mmap_mode="r")
isoscope.marching_cubes(np.array(source[:67, :67, :67]), 0.0, chunks=64)  # GL context, compiled programs
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
verts, faces, _, _ = isoscope.marching_cubes(source, 0.0, gradient_direction="ascent", chunks=64)
after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps({"grew_kib": after - before, "triangles": len(faces)}))
"""


@pytest.mark.gl
def test_peak_memory_is_bounded_by_the_chunk_not_the_volume(tmp_path):
    """A 256^3 float32 file (64 MiB) memory-mapped, in boxes of 64^3 cells (1.2 MiB): the process's
    peak resident memory grows by far less than the volume (the mesh: ~30 k vertices)."""
    n = 256
    path = tmp_path / "sphere.npy"
    out = np.lib.format.open_memmap(path, mode="w+", dtype=np.float32, shape=(n, n, n))
    axis = np.arange(n, dtype=np.float32) - n / 2
    for i in range(n):
        out[i] = np.sqrt(axis[i] ** 2 + axis[:, None] ** 2 + axis[None, :] ** 2) - 40
    out.flush()
    del out
    result = subprocess.run([sys.executable, "-c", PEAK_SCRIPT, str(path)], capture_output=True, text=True,
                            check=True)
    measured = json.loads(result.stdout.strip().splitlines()[-1])
    assert measured["triangles"] > 50_000
    assert measured["grew_kib"] < 16 * 1024, measured  # the whole volume would be 65,536 KiB


@pytest.mark.gl
def test_a_nan_is_reported_at_its_place_in_the_whole_volume():
    volume = smooth_noise((30, 30, 30))
    volume[21, 17, 25] = np.nan
    with pytest.raises(ValueError, match=r"at index \(21, 17, 25\)"):
        isoscope.marching_cubes(volume, 0.0, chunks=8)


@pytest.mark.parametrize("topology", ["montani", "trilinear"])
def test_float64_samples_that_float32_rounds_onto_the_level_are_not_skipped(topology):
    """A box whose float64 samples all lie just below the level, where float32 (the extractors' comparison)
    rounds them onto it, has a surface: it was skipped by a range test in float64, and its part went missing."""
    from isoscope.api import outward_marching_cubes
    volume = np.zeros((6, 6, 12))
    volume[:, :, 6:] = 0.1 - 1e-10          # float32(0.1 - 1e-10) == float32(0.1): inside for the extractors
    volume[2:4, 2:4, 2:4] = 0.2
    whole = outward_marching_cubes(volume, 0.1, backend="cpu", topology=topology)
    stitched = outward_marching_cubes(volume, 0.1, backend="cpu", topology=topology, chunks=(5, 5, 5))
    for a, b in zip(whole, stitched):
        np.testing.assert_array_equal(a, b)

"""A scan given --labels is refused before anything is written (issue 35): a segmentation fills flat
regions (neighbouring voxels inside it mostly hold the same label), a scan's values change from voxel to
voxel.  FreeSurfer-like (values up to 2035) and TotalSegmentator-like (117 labels) maps pass; an 8-bit MRI,
whose 255 values pass any label limit, does not, unless --force-labels."""
from __future__ import annotations

import tracemalloc

import nibabel as nib
import numpy as np
import pytest
from scipy import ndimage
from support.command import assert_one_line_error, isoscope_here

import isoscope
from isoscope.labels import looks_like_a_scan

SHAPE = (64, 72, 56)


def _head(seed=0) -> np.ndarray:
    """An 8-bit MRI-like head: a smooth ellipsoid of tissue with noise, the values a continuous run of grey."""
    rng = np.random.default_rng(seed)
    z, y, x = np.meshgrid(*(np.linspace(-1, 1, n) for n in SHAPE), indexing="ij")
    inside = (x * x / 0.8 + y * y / 0.9 + z * z / 0.7) < 1
    tissue = 120 + 60 * ndimage.gaussian_filter(rng.standard_normal(SHAPE), 4) + 12 * rng.standard_normal(SHAPE)
    return np.where(inside, np.clip(tissue, 1, 255), 0).astype(np.uint8)


def _parcels(values: np.ndarray, seed=0) -> np.ndarray:
    """A label map of the head's shape: Voronoi parcels of the tissue, each one of `values`."""
    rng = np.random.default_rng(seed)
    seeds = np.zeros(SHAPE, np.int32)
    points = rng.integers(0, SHAPE, size=(len(values), 3))
    seeds[tuple(points.T)] = np.arange(1, len(values) + 1)
    _, nearest = ndimage.distance_transform_edt(seeds == 0, return_indices=True)
    parcel = seeds[tuple(nearest)]
    labels = np.concatenate([[0], values])[parcel]
    return np.where(_head() > 0, labels, 0)


def test_scans_look_like_scans_and_label_maps_like_label_maps():
    assert looks_like_a_scan(_head()) is not None
    freesurfer = np.concatenate([np.arange(2, 80), np.arange(1001, 1036), np.arange(2001, 2036)]).astype(np.int32)
    assert looks_like_a_scan(_parcels(freesurfer)) is None   # aparc+aseg: values up to 2035
    assert looks_like_a_scan(_parcels(np.arange(1, 118)).astype(np.uint8)) is None   # TotalSegmentator: 117
    assert looks_like_a_scan((_head() > 120).astype(np.uint8)) is None   # a mask
    assert looks_like_a_scan(np.zeros(SHAPE, np.uint8)) is None   # nothing to tell by: not refused here


def test_a_scan_given_labels_writes_nothing_and_force_labels_overrides(tmp_path):
    path = tmp_path / "mri.nii.gz"
    nib.save(nib.Nifti1Image(_head(), np.eye(4)), path)
    out = tmp_path / "out"
    out.mkdir()
    for command in (("export", path, "--labels", "--out", out / "m.stl"), ("measure", path, "--labels")):
        assert_one_line_error(isoscope_here(*command), "looks like a scan", "--force-labels")
    assert not list(out.iterdir())
    forced = isoscope_here("export", path, "--labels", "--force-labels", "--max-labels", "255", "--out", out / "m.stl")
    assert forced.returncode == 0, forced.stderr
    assert len(list(out.iterdir())) > 100
    assert_one_line_error(isoscope_here("measure", path, "--force-labels"), "--force-labels needs --labels")


@pytest.mark.gl
def test_render_refuses_a_scan_as_labels(tmp_path):
    path = tmp_path / "mri.npy"
    np.save(path, _head())
    assert_one_line_error(isoscope_here("render", path, "--labels", "--out", tmp_path / "x.png"), "looks like a scan")
    assert not (tmp_path / "x.png").exists()


def test_a_float_label_past_what_a_float_numbers_is_refused(tmp_path):
    data = np.zeros((12, 12, 12))
    data[3:8, 3:8, 3:8] = 1e30
    np.save(tmp_path / "f.npy", data)
    assert_one_line_error(isoscope_here("measure", tmp_path / "f.npy", "--labels"), "1e+30", "not a label map")


def test_label_colours_are_sized_by_the_count_of_labels_not_their_values():
    seg = np.zeros((16, 16, 16), np.int64)
    seg[2:7, 2:7, 2:7], seg[8:14, 4:9, 4:9] = 7, 2_000_000_000
    tracemalloc.start()
    try:
        mesh = isoscope.isosurface(seg, labels=True, backend="cpu")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 50 << 20, peak   # a palette by value: 2e9 colours, 48 GB
    assert len(np.unique(mesh.visual.vertex_colors[:, :3], axis=0)) == 2
    seg[seg == 7] = -5   # indexed by value, a negative label was an IndexError
    assert len(np.unique(isoscope.isosurface(seg, labels=True, backend="cpu").visual.vertex_colors[:, :3],
                         axis=0)) == 2

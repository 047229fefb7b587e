"""Volumes larger than RAM: Zarr v2/v3 and OME-Zarr opened lazily, big .npy and raw files memory-mapped."""
from __future__ import annotations

import numpy as np
import pytest
import zarr
from support.ome_zarr import write_ome

import isoscope
from isoscope.core.lazy_arrays import is_lazy
from isoscope.volumes import VolumeError, open_volume

RNG = np.random.default_rng(5)


@pytest.fixture
def field():
    from scipy.ndimage import gaussian_filter
    return gaussian_filter(RNG.normal(size=(30, 26, 40)), 2).astype(np.float32)


@pytest.mark.parametrize("zarr_format", [2, 3])
def test_zarr_array_opens_lazily_with_its_values(tmp_path, field, zarr_format):
    path = tmp_path / "v.zarr"
    array = zarr.create_array(str(path), shape=field.shape, chunks=(8, 8, 8), dtype="f4", zarr_format=zarr_format)
    array[:] = field
    volume = open_volume(str(path))
    assert is_lazy(volume.data) and volume.data.shape == field.shape
    assert volume.value_range == (float(field.min()), float(field.max()))
    np.testing.assert_array_equal(np.asarray(volume.data), field)
    np.testing.assert_array_equal(volume.checked.data, field)  # read whole for the viewer, once
    assert volume.checked.data is volume.checked.data


def _ome(tmp_path, field, zarr_format, scale, leading=()):
    """An OME-Zarr image with two levels, its multiscales metadata written by hand (0.4 for v2, 0.5 for v3)."""
    path = tmp_path / "image.ome.zarr"
    axes = [{"name": n, "type": t} for n, t in (("t", "time"), ("c", "channel"))[:len(leading)]]
    axes += [{"name": n, "type": "space", "unit": "micrometer"} for n in "zyx"]
    full = field.reshape(leading + field.shape) if leading else field
    scales = [[1.0] * len(leading) + [s * 2 ** level for s in scale] for level in range(2)]
    write_ome(path, [full, full[..., ::2, ::2, ::2]], scales, axes, zarr_format)
    return path


@pytest.mark.parametrize("zarr_format", [2, 3])
def test_ome_zarr_full_resolution_level_and_its_spacing(tmp_path, field, zarr_format):
    volume = open_volume(str(_ome(tmp_path, field, zarr_format, (2.0, 0.5, 0.25))))
    assert volume.spacing == (2.0, 0.5, 0.25)
    np.testing.assert_array_equal(np.asarray(volume.data), field)
    assert any("full resolution" in note for note in volume.notes)


def test_ome_zarr_time_and_channel_axes_pick_a_frame(tmp_path, field):
    stack = np.stack([field, field + 1.0])[:, None]  # t=2, c=1
    path = tmp_path / "tc.ome.zarr"
    group = zarr.open_group(str(path), mode="w", zarr_format=2)
    group.create_array("0", shape=stack.shape, chunks=(1, 1, 8, 8, 8), dtype="f4")[:] = stack
    axes = [{"name": "t", "type": "time"}, {"name": "c", "type": "channel"}] + \
        [{"name": n, "type": "space"} for n in "zyx"]
    group.attrs["multiscales"] = [{"version": "0.4", "axes": axes, "datasets": [
        {"path": "0", "coordinateTransformations": [{"type": "scale", "scale": [1, 1, 3, 2, 1]}]}]}]
    assert np.asarray(open_volume(str(path), time=1).data).min() == field.min() + 1.0
    assert open_volume(str(path)).spacing == (3.0, 2.0, 1.0)
    with pytest.raises(VolumeError, match="--time 2 is past the end: tc.ome.zarr has 2 time points"):
        open_volume(str(path), time=2)


def test_chunked_mesh_of_a_zarr_volume_equals_the_in_memory_mesh(tmp_path, field, gl_ctx):
    path = _ome(tmp_path, field, 3, (1.0, 1.0, 1.0))
    volume = open_volume(str(path))
    whole = isoscope.marching_cubes(field, 0.0, backend="gpu")
    stitched = isoscope.marching_cubes(volume.data, 0.0, chunks=11, backend="gpu")
    for got, expected in zip(stitched, whole):
        np.testing.assert_array_equal(got, expected)


def test_a_directory_that_is_not_zarr_is_not_taken_for_one(tmp_path):
    (tmp_path / "broken.zarr").mkdir()
    with pytest.raises(VolumeError, match="broken.zarr is damaged"):
        open_volume(str(tmp_path / "broken.zarr"))


@pytest.fixture
def map_everything(monkeypatch):
    """Map files from 1 byte up, and pretend this machine has 1 MiB free: the big-file path on small files."""
    from isoscope.volumes import npy_format, raw_format, volume
    for module in (npy_format, raw_format):
        monkeypatch.setattr(module, "MAP_BYTES", 1)
    monkeypatch.setattr(volume, "available_memory_bytes", lambda: 1 << 20)


def test_npy_larger_than_memory_is_mapped_not_read(tmp_path, field, map_everything, gl_ctx):
    big = np.tile(field, (2, 2, 2))  # 2.5 MiB, more than the pretended 0.5 MiB budget
    np.save(tmp_path / "big.npy", big)
    volume = open_volume(str(tmp_path / "big.npy"))
    assert isinstance(volume.data.base, np.memmap)  # a view of the map, not a copy
    np.testing.assert_array_equal(isoscope.marching_cubes(volume.data, 0.0, chunks=20)[1],
                                  isoscope.marching_cubes(big, 0.0, backend="gpu")[1])


def test_raw_larger_than_memory_is_mapped_x_first(tmp_path, field, map_everything):
    big = np.tile(field, (2, 2, 2))
    big.transpose(2, 1, 0).tofile(tmp_path / "big.raw")  # x fastest on disk
    volume = open_volume(str(tmp_path / "big.raw"), dims=big.shape, dtype="float32")
    assert is_lazy(volume.data) and volume.data.shape == big.shape
    np.testing.assert_array_equal(np.asarray(volume.data[3:9, 5:7, 1:30]), big[3:9, 5:7, 1:30])
    with pytest.raises(VolumeError, match="more than this machine.*--chunk"):
        _ = volume.checked  # the viewer's whole read is refused, naming the way out


def test_map_files_maps_a_small_c_ordered_npy_and_reads_a_fortran_one(tmp_path, field):
    """open_volume(map_files=True): a C-ordered .npy of any size is memory-mapped (the viewer's bricks then read
    it a block at a time, the benchmark's --memmap), not read into memory; a Fortran-ordered one is still read."""
    np.save(tmp_path / "small.npy", field)
    np.save(tmp_path / "fortran.npy", np.asfortranarray(field))
    mapped = open_volume(str(tmp_path / "small.npy"), map_files=True)
    assert isinstance(mapped.data.base, np.memmap)
    np.testing.assert_array_equal(mapped.data, field)
    assert not isinstance(open_volume(str(tmp_path / "small.npy")).data.base, np.memmap)
    read = open_volume(str(tmp_path / "fortran.npy"), map_files=True)
    assert not isinstance(read.data.base, np.memmap)
    np.testing.assert_array_equal(read.data, field)


def test_a_file_over_half_the_viewer_s_budget_is_mapped_not_read(tmp_path, field):
    """The window (--memory-budget) and the panel's Open map a C-ordered .npy that takes more than half the
    budget, as export does, instead of reading it whole before the bricks read it a block at a time; a file
    well within the budget is still read."""
    import argparse

    from isoscope.cli.volume_options import open_volume_from_args
    from isoscope.core.budget import MemoryBudget
    from isoscope.viewer.model.opening import read_for_viewer

    np.save(tmp_path / "field.npy", field)
    path = str(tmp_path / "field.npy")
    size = (tmp_path / "field.npy").stat().st_size
    names = ("dims", "dtype", "endian", "spacing", "time", "series", "resolution", "inside")
    for budget, mapped in ((size, True), (4 * size, False)):
        args = argparse.Namespace(**dict.fromkeys(names), memory_budget=budget)
        assert isinstance(open_volume_from_args(path, args).data.base, np.memmap) is mapped
        opened = read_for_viewer(open_volume, path, {}, MemoryBudget(budget, "--memory-budget"))
        assert isinstance(opened.volume.data.base, np.memmap) is mapped
        np.testing.assert_array_equal(opened.volume.data, field)

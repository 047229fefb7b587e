"""One check for every volume (validation.check_volume): what it refuses, and that nothing scans twice."""
from __future__ import annotations

import tracemalloc
import warnings

import numpy as np
import pytest

import isoscope
from isoscope.gpu.cubes import Extractor
from isoscope.validation import check_volume
from isoscope.volumes import VolumeError, open_volume


def test_values_beyond_float32_are_named_as_such_without_a_numpy_warning():
    volume = np.ones((4, 4, 4))
    volume[1, 2, 3] = 1e39  # finite in float64, inf once cast to float32
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a RuntimeWarning from a cast would fail here
        with pytest.raises(ValueError) as err:
            isoscope.marching_cubes(volume, 1.0, backend="cpu")
    message = str(err.value)
    assert "float32" in message and "1e+39" in message and "rescale" in message
    assert "NaN" not in message and "\n" not in message


def test_negative_overflow_and_a_file_get_the_same_message(tmp_path):
    volume = np.ones((4, 4, 4))
    volume[0, 0, 0] = -3e38 * 10
    np.save(tmp_path / "big.npy", volume)
    with pytest.raises(VolumeError, match="beyond float32's range"):
        open_volume(str(tmp_path / "big.npy"))


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_non_finite_samples_in_any_slab_are_found_counted_and_placed(monkeypatch, bad, dtype):
    # The scan finds them through each slab's min and max; every slab must be looked at, and the
    # message must still name the first one and the count (two here, in different slabs).
    monkeypatch.setattr("isoscope.validation.CHECK_SLAB_BYTES", 6 * 7 * np.dtype(dtype).itemsize * 2)
    volume = np.linspace(-1, 1, 9 * 6 * 7).astype(dtype).reshape(9, 6, 7)
    volume[7, 4, 5] = bad
    volume[8, 0, 1] = np.nan
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ValueError) as err:
            check_volume(volume)
    message = str(err.value)
    assert "2 NaN/Inf sample(s)" in message and "(7, 4, 5)" in message and "\n" not in message
    volume[7, 4, 5] = volume[8, 0, 1] = 0.5  # and once they are gone, the range is the samples'
    assert check_volume(volume).value_range == (-1.0, 1.0)


def test_a_checked_volume_passes_through_unchanged():
    checked = check_volume(np.arange(27, dtype=np.int16).reshape(3, 3, 3))
    assert checked.data.dtype == np.int16  # integers stay integers
    assert checked.value_range == (0.0, 26.0)
    assert check_volume(checked) is checked


def test_the_extractor_takes_a_loaded_volume_without_a_full_size_copy(gl_ctx):
    # The viewer's path: a loader checked the volume once; the extractor must neither scan it
    # again (a full-size finiteness mask) nor convert it whole to float32 (4x a uint8 volume).
    volume = open_volume("bucky:256")
    assert volume.data.dtype == np.uint8
    tracemalloc.start()
    try:
        with Extractor(volume.checked, ctx=gl_ctx) as ex:
            _, peak = tracemalloc.get_traced_memory()
            assert ex.value_range == volume.value_range
    finally:
        tracemalloc.stop()
    # uint8 with rows of whole texels goes up as it is: not even one copy.
    assert peak < volume.data.nbytes // 4, f"{peak >> 20} MiB allocated for a {volume.data.nbytes >> 20} MiB volume"


@pytest.mark.parametrize("dtype, texel", [("uint8", "u1"), ("int8", "i1"), ("uint16", "u2"), ("int16", "i2"),
                                          ("int32", "f4"), ("float64", "f4")])
@pytest.mark.parametrize("n2", [40, 37])  # rows of whole texels go up as they are; others are padded
def test_scans_stay_integers_on_the_gpu_and_give_the_mesh_of_their_float32_values(gl_ctx, dtype, texel, n2):
    rng = np.random.default_rng(3)
    volume = rng.integers(-100 if dtype.startswith("int") else 0, 100, size=(19, 23, n2)).astype(dtype)
    with Extractor(volume, ctx=gl_ctx) as ex:
        assert ex.resident.texture.dtype == texel  # 8- and 16-bit samples keep their size on the GPU
        ex.extract(50)
        from_scan = ex.read_mesh()
    with Extractor(volume.astype(np.float32), ctx=gl_ctx) as ex:
        ex.extract(50)
        from_floats = ex.read_mesh()
    assert len(from_scan[1]) > 100
    for a, b in zip(from_scan, from_floats):
        assert np.array_equal(a, b)

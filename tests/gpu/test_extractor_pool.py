"""The extractor kept between one-shot calls (isoscope.gpu.pool): reused only where it fits, and every
call's mesh is its own volume's (against the numpy reference, which never touches the GPU)."""
from __future__ import annotations

import numpy as np
import pytest
from conftest import grid
from support.mesh_checks import assert_same_mesh

import isoscope
from isoscope.api import outward_marching_cubes
from isoscope.gpu import pool as extractor_pool
from isoscope.gpu.cubes import Extractor
from isoscope.validation import check_volume


def ball(n, radius, centre=(0.03, -0.02, 0.01), dtype=np.float32):
    x, y, z = grid(n)
    return (np.sqrt((x - centre[0]) ** 2 + (y - centre[1]) ** 2 + (z - centre[2]) ** 2) - radius).astype(dtype)


def both(volume, level, **kwargs):
    return (isoscope.marching_cubes(volume, level, backend="gpu", **kwargs),
            isoscope.marching_cubes(volume, level, backend="cpu", **kwargs))


@pytest.fixture(autouse=True)
def empty_pool(gl_ctx):
    isoscope.release_gpu_memory()
    yield
    isoscope.release_gpu_memory()


def reused():
    return extractor_pool.stats()["reused_calls"]


def test_calls_on_volumes_of_one_shape_reuse_one_extractor_and_each_gets_its_own_mesh():
    first = reused()
    for radius, spacing, direction in ((0.5, (1, 1, 1), "ascent"), (0.7, (0.5, 1.0, 2.0), "ascent"),
                                       (0.6, (1, 1, 1), "descent")):
        volume = ball(28, radius)
        gpu, cpu = both(volume, 0.0, spacing=spacing, gradient_direction=direction)
        assert_same_mesh(gpu, cpu)
        assert len(gpu[1]) > 100
    assert reused() == first + 2  # the second and third calls wrote their samples into the first's image
    assert extractor_pool.stats()["kept_bytes"] > ball(28, 0.5).nbytes


@pytest.mark.parametrize("other", ["shape", "dtype"])
def test_a_volume_of_another_shape_or_sample_type_gets_a_new_extractor(other):
    isoscope.marching_cubes(ball(24, 0.5), 0.0, backend="gpu")
    volume = ball(30, 0.6) if other == "shape" else (ball(24, 0.6) < 0).astype(np.uint8) * 200
    level = 0.0 if other == "shape" else 100.0
    first = reused()
    gpu, cpu = both(volume, level)
    assert_same_mesh(gpu, cpu)
    assert reused() == first


def test_tetrahedra_after_cubes_read_the_new_volume():
    isoscope.marching_cubes(ball(24, 0.4), 0.0, backend="gpu")
    volume = ball(24, 0.65)
    gpu = isoscope.marching_tetrahedra(volume, 0.0, backend="gpu")
    cpu = isoscope.marching_tetrahedra(volume, 0.0, backend="cpu")
    assert_same_mesh(gpu, cpu)


def test_release_gives_the_memory_back_and_the_next_call_starts_afresh():
    isoscope.marching_cubes(ball(24, 0.5), 0.0, backend="gpu")
    held = extractor_pool.stats()["kept_bytes"]
    assert isoscope.release_gpu_memory() == held > 0
    assert extractor_pool.stats()["kept_bytes"] == 0 and isoscope.release_gpu_memory() == 0
    first = reused()
    assert_same_mesh(*both(ball(24, 0.6), 0.0))
    assert reused() == first


def test_a_failure_while_it_is_in_use_releases_it(gl_ctx):
    checked = check_volume(ball(24, 0.5))
    with pytest.raises(RuntimeError, match="stop here"):
        with extractor_pool.pooled_extractor(checked, (1, 1, 1), "descent") as extractor:
            extractor.extract(0.0)
            raise RuntimeError("stop here")
    assert extractor.vertex_buffer is None  # released, and not kept
    assert extractor_pool.stats()["kept_bytes"] == 0
    assert_same_mesh(*both(ball(24, 0.6), 0.0))


def test_an_extractor_over_the_limit_is_not_kept(monkeypatch):
    monkeypatch.setattr(extractor_pool, "KEEP_LIMIT_BYTES", 1024)
    assert_same_mesh(*both(ball(24, 0.6), 0.0))
    assert extractor_pool.stats()["kept_bytes"] == 0


def test_a_call_while_the_kept_one_is_in_use_gets_its_own(gl_ctx):
    checked = check_volume(ball(24, 0.5))
    with extractor_pool.pooled_extractor(checked, (1, 1, 1), "descent") as outer:
        outer.extract(0.0)
        inner = isoscope.marching_cubes(ball(24, 0.7), 0.0, backend="gpu")  # the outer one is busy
        assert_same_mesh(outer.read_mesh(), outward_marching_cubes(ball(24, 0.5), 0.0, backend="cpu"))
    assert_same_mesh(inner, isoscope.marching_cubes(ball(24, 0.7), 0.0, backend="cpu"))


def test_reload_refuses_a_volume_that_does_not_fit_and_keeps_the_old_one(gl_ctx):
    volume = ball(20, 0.5)
    with Extractor(volume, ctx=gl_ctx) as extractor:
        assert extractor.fits(ball(20, 0.3)) and not extractor.fits(ball(21, 0.3))
        assert not extractor.fits(ball(20, 0.3, dtype=np.int16))
        with pytest.raises(ValueError, match="does not fit"):
            extractor.reload(ball(21, 0.3))
        extractor.extract(0.0)
        assert_same_mesh(extractor.read_mesh(), outward_marching_cubes(volume, 0.0, backend="cpu"))
        # float64 samples go up as float32, as the first volume did: they fit
        wider = ball(20, 0.62, dtype=np.float64)
        extractor.reload(wider, spacing=(2.0, 1.0, 1.0))
        assert extractor.level is None and extractor.value_range == (float(wider.min()), float(wider.max()))
        extractor.extract(0.0)
        assert_same_mesh(extractor.read_mesh(),
                         outward_marching_cubes(wider.astype(np.float32), 0.0, spacing=(2, 1, 1), backend="cpu"))


# -- values scanned on upload (check_volume(scan_values=False), ResidentVolume._value_range) ----------------

@pytest.mark.parametrize("dtype", ["float32", "uint8", "int8", "uint16", "int16"])
def test_the_upload_scan_finds_numpys_value_range(gl_ctx, dtype):
    rng = np.random.default_rng(11)
    info = np.iinfo(dtype) if dtype != "float32" else None
    for shape in ((5, 7, 70), (2, 2, 2), (9, 33, 129)):  # partial texels and words, one texel, several words
        if info is None:
            volume = (rng.normal(size=shape) * 1e3).astype(dtype)
        else:
            volume = rng.integers(info.min, info.max, size=shape, endpoint=True).astype(dtype)
        unscanned = check_volume(volume, scan_values=False)
        assert unscanned.value_range is None
        with Extractor(unscanned, ctx=gl_ctx) as ex:
            assert ex.value_range == (float(volume.min()), float(volume.max()))


def test_volumes_the_gpu_does_not_hold_exactly_are_still_scanned_by_numpy():
    for volume in (np.zeros((4, 4, 4), np.float64), np.zeros((4, 4, 4), np.int32)):
        assert check_volume(volume, scan_values=False).value_range == (0.0, 0.0)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_a_non_finite_sample_found_on_upload_gets_the_scans_own_error(bad):
    volume = ball(24, 0.5)
    volume[3, 17, 22] = bad
    with pytest.raises(ValueError) as cpu:
        isoscope.marching_cubes(volume, 0.0, backend="cpu")
    for call in (lambda: isoscope.marching_cubes(volume, 0.0, backend="gpu"),
                 lambda: isoscope.marching_tetrahedra(volume, 0.0, backend="gpu")):
        with pytest.raises(ValueError) as gpu:
            call()
        assert str(gpu.value) == str(cpu.value)
        assert "at index (3, 17, 22)" in str(gpu.value)
    good = ball(24, 0.5)  # the same shape: the next call starts afresh and is right
    assert_same_mesh(*both(good, 0.0))


def test_a_level_outside_the_scanned_range_is_refused_and_the_extractor_kept():
    volume = ball(20, 0.5)
    isoscope.marching_cubes(volume, 0.0, backend="gpu")
    kept, first = extractor_pool.stats()["kept_bytes"], reused()
    with pytest.raises(ValueError, match="outside the data range"):
        isoscope.marching_cubes(volume, 5.0, backend="gpu")
    assert extractor_pool.stats()["kept_bytes"] == kept > 0
    assert_same_mesh(*both(volume, 0.0))
    assert reused() == first + 2


def test_the_default_level_is_the_middle_of_the_scanned_range():
    volume = (ball(21, 0.4) * 100).astype(np.int16)
    gpu, cpu = both(volume, None)
    assert_same_mesh(gpu, cpu)
    assert len(gpu[0]) > 0


def test_an_unscanned_volume_passed_to_the_numpy_paths_is_scanned_there():
    volume = ball(16, 0.5)
    unscanned = check_volume(volume, scan_values=False)
    assert_same_mesh(isoscope.marching_cubes(unscanned, None, backend="cpu"), isoscope.marching_cubes(volume, None))
    assert check_volume(unscanned).value_range == (float(volume.min()), float(volume.max()))
    volume[2, 3, 4] = np.nan
    with pytest.raises(ValueError, match=r"NaN/Inf .* at index \(2, 3, 4\)"):
        isoscope.smooth_mesh(check_volume(volume, scan_values=False), np.zeros((0, 3)), np.zeros((0, 3), int), 0.0)


@pytest.mark.parametrize("step", [0, 1.5, np.array([1, 2])])
def test_a_bad_step_size_gets_its_own_error_on_the_gpu_path(step):
    with pytest.raises(ValueError, match="step_size must be a whole number"):
        isoscope.marching_cubes(ball(8, 0.5), 0.0, step_size=step, backend="gpu")

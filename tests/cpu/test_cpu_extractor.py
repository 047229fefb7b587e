"""The resident CPU extractor: the GPU Extractor's methods, the numpy reference's mesh."""
from __future__ import annotations

import numpy as np
import pytest

import isoscope
from isoscope.cpu.cubes import marching_cubes_reference
from isoscope.cpu.extractor import CpuExtractor
from isoscope.validation import check_volume


def _ball(n=24):
    x, y, z = np.mgrid[-1:1:n * 1j, -1:1:n * 1j, -1:1:n * 1j]
    return (1 - np.sqrt(x * x + y * y + z * z)).astype(np.float32)


@pytest.mark.parametrize("backend", ["cpu", "numpy"])
@pytest.mark.parametrize("direction", ["descent", "ascent"])
def test_extract_then_read_gives_marching_cubes_mesh(direction, backend):
    ball = _ball()
    spacing = (0.5, 1.0, 2.0)
    with CpuExtractor(ball, spacing=spacing, gradient_direction=direction, backend=backend) as ex:
        assert ex.shape == ball.shape and ex.spacing == spacing and ex.level is None
        assert ex.value_range == (float(ball.min()), float(ball.max()))
        for level in (0.5, 0.25):
            counts = ex.extract(level)
            mesh = ex.read_mesh()
            assert ex.level == level and counts == (len(mesh[0]), len(mesh[1]))
            expected = marching_cubes_reference(ball, level, spacing, direction == "descent")
            for got, want in zip(mesh, expected):
                assert got.dtype == want.dtype
                np.testing.assert_array_equal(got, want)


def test_takes_a_checked_volume_and_integers():
    volume = (np.arange(5 * 6 * 7).reshape(5, 6, 7) % 11).astype(np.uint8)
    with CpuExtractor(check_volume(volume)) as ex:
        assert ex.value_range == (0.0, 10.0)
        assert ex.extract(4.5)[1] > 0


def test_bad_arguments_and_use_after_release():
    with pytest.raises(ValueError, match="backend"):
        CpuExtractor(_ball(), backend="gpu")
    ex = CpuExtractor(_ball())
    with pytest.raises(ValueError, match="outside the data range"):
        ex.extract(5.0)
    with pytest.raises(ValueError, match="extract"):
        ex.read_mesh()
    ex.release()
    ex.release()
    for use in (lambda: ex.extract(0.5), ex.read_mesh):   # one line saying so, not an AttributeError
        with pytest.raises(isoscope.IsoscopeError, match="released.*make a new one"):
            use()


def test_examples_run():
    import doctest

    import isoscope.cpu.extractor as module
    result = doctest.testmod(module, report=False)
    assert result.attempted > 0 and result.failed == 0


def test_levels_up_and_down_reuse_the_outputs_and_keep_the_mesh():
    """The compiled extractor writes each level into the arrays of the last (grown when too small)."""
    rng = np.random.default_rng(7)
    volume = rng.normal(size=(30, 40, 50)).astype(np.float32)
    with CpuExtractor(volume) as ex:
        for level in (2.0, 0.0, 2.5, 0.3, 0.0):
            ex.extract(level)
            kept = ex.mesh
            for got, want in zip(ex.read_mesh(), marching_cubes_reference(volume, level)):
                np.testing.assert_array_equal(got, want)
            assert len(kept[0]) == ex.n_vertices and len(kept[1]) == ex.n_triangles

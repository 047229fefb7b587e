"""Every refusal of the Python API is an isoscope.IsoscopeError (a ValueError too for bad input), in one
line (issue 35): sizes, angles, smoothing, a dask array of many chunks, a missing optional package."""
from __future__ import annotations

import sys

import numpy as np
import pytest

import isoscope


def _ball(n=16):
    axis = np.linspace(-1, 1, n, dtype=np.float32)
    x, y, z = np.meshgrid(axis, axis, axis, indexing="ij")
    return 0.6 - np.sqrt(x * x + y * y + z * z)


@pytest.mark.parametrize("options, words", [
    ({"size": (0, 0)}, r"size \(0, 0\)"), ({"size": (-800, 600)}, "-800"), ({"size": "axb"}, "not a number"),
    ({"size": "800"}, "WIDTHxHEIGHT"),
    ({"azimuth": float("nan")}, "azimuth"), ({"elevation": 120}, "elevation 120"),
    ({"smooth": 10**9}, "smooth 1000000000"), ({"smooth": -1}, "smooth"),
])
def test_render_refuses_in_one_line_before_any_work(options, words):
    with pytest.raises(isoscope.IsoscopeError, match=words) as caught:
        isoscope.render(_ball(), 0.0, **options)
    assert isinstance(caught.value, ValueError) and "\n" not in str(caught.value)


@pytest.mark.gl
def test_render_takes_a_size_as_the_command_writes_it():
    assert isoscope.render(_ball(), 0.0, size="96x64").shape == (64, 96, 4)


@pytest.mark.gl
def test_render_of_a_dask_array_of_many_chunks():
    da = pytest.importorskip("dask.array")
    ball = _ball(24)
    lazy = da.from_array(ball, chunks=8)
    assert lazy.numblocks == (3, 3, 3)
    assert np.array_equal(isoscope.render(lazy, 0.0, size=(80, 60), slices=[(2, 12)]),
                          isoscope.render(ball, 0.0, size=(80, 60), slices=[(2, 12)]))


def test_widget_names_the_one_package_missing(monkeypatch):
    pytest.importorskip("ipywidgets")
    monkeypatch.setitem(sys.modules, "jupyter_rfb", None)   # import fails as if not installed
    with pytest.raises(isoscope.IsoscopeError, match="needs jupyter-rfb, which is not installed") as caught:
        isoscope.widget(_ball())
    assert isinstance(caught.value, ImportError) and "ipywidgets," not in str(caught.value)

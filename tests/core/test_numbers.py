"""One spec per number a user gives (core/numbers.py): the same range refused in the same words from the
command line, a scene and Python, before any work starts."""
from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

import isoscope
from isoscope.core.numbers import FPS, FRAMES, IMAGE_SIDE, SMOOTH, image_size

SPECS = (SMOOTH, FPS, FRAMES, IMAGE_SIDE)


@given(value=st.one_of(st.integers(-10**12, 10**12), st.floats(allow_nan=True, allow_infinity=True),
                       st.booleans(), st.text(max_size=8), st.none()))
def test_every_value_is_taken_in_range_or_refused_in_one_line(value):
    for spec in SPECS:
        try:
            checked = spec.check(value)
        except isoscope.IsoscopeError as exc:
            assert isinstance(exc, ValueError)
            assert "\n" not in str(exc) and spec.flag in str(exc) and "e.g." in str(exc)
            continue
        assert not isinstance(value, (bool, str)) and value is not None
        assert math.isfinite(checked) and spec.low <= checked <= spec.high
        assert checked == value and (type(checked) is int) == spec.whole


def test_the_hangs_of_the_last_round_are_refused_before_work():
    with pytest.raises(isoscope.IsoscopeError, match="0 to 500"):
        SMOOTH.check(1_000_000_000)
    with pytest.raises(isoscope.IsoscopeError, match="more than 0"):
        FPS.check(0)
    assert SMOOTH.parse("5.0") == 5 and FPS.parse("24") == 24.0


@pytest.mark.parametrize("size", [(0, 0), (-800, 600), "0x0", "800 by 600", (800,), "axb", (800.5, 600), None, 7])
def test_image_sizes_that_make_no_image_are_one_line(size):
    with pytest.raises(isoscope.IsoscopeError, match="size") as caught:
        image_size(size)
    assert "\n" not in str(caught.value)


def test_image_sizes_as_users_write_them():
    assert image_size("800x600") == (800, 600) == image_size((800.0, 600)) == image_size([800, 600])

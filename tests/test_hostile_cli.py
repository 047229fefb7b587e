"""Hostile input from users' reports (issue 22), each run as a user would: a real `python -m isoscope`
subprocess on real files, held to the promise (exit 2, one `isoscope: error:` line, seconds, little
memory; tests/hostile.py), plus the pure rules behind the refusals."""
from __future__ import annotations

import json

import numpy as np
import pytest
from hostile import refused


@pytest.fixture
def raw8(tmp_path):
    path = tmp_path / "tiny.raw"
    np.arange(8, dtype=np.uint8).tofile(path)
    return path


# --- 3. dims whose product wraps, or that are not integers at all --------------------------------------

@pytest.mark.parametrize("dims, words", [(("4294967296", "4294967296", "8"), ("--dims", "2147483647")),
                                         (("2147483647", "2147483647", "8"), ("voxels", "more than"))])
def test_dims_whose_int64_product_wraps_are_refused(raw8, tmp_path, dims, words):
    refused("export", raw8, "--dims", *dims, "--out", tmp_path / "o.stl", words=words)


def test_sidecar_dims_of_1e308_are_one_line(raw8, tmp_path):
    (tmp_path / "tiny.raw.json").write_text(json.dumps({"dims": [1e308, 1, 1]}))
    refused("export", raw8, "--out", tmp_path / "o.stl", words=("dims", "positive whole numbers"))


def test_three_positive_takes_python_ints_and_refuses_overflow():
    from isoscope.volumes.errors import VolumeError
    from isoscope.volumes.raw_format import MAX_DIM, three_positive
    assert three_positive([4, 5, 6], "--dims", int, "x") == (4, 5, 6)
    for bad in ([1e308, 1, 1], [float("inf"), 1, 1], [MAX_DIM + 1, 1, 1], [2.5, 1, 1], [True, 1, 1], 5, "123"):
        with pytest.raises(VolumeError):
            three_positive(bad, "--dims", int, "x")
    with pytest.raises(VolumeError):
        three_positive([float("inf"), 1, 1], "--spacing", float, "x")

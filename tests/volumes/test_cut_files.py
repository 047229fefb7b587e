"""Files cut off or empty (issue 35's regressions): an empty or 100-byte .nii.gz, an empty or header-only
.nrrd, and a 4-D NIfTI whose header claims more time points than it holds are one line, not a traceback
and not a volume."""
from __future__ import annotations

import gzip

import nibabel as nib
import numpy as np
import pytest
from support.command import assert_one_line_error, isoscope_here


def _series(path):
    data = np.random.default_rng(0).random((8, 8, 8, 5)).astype(np.float32)
    nib.save(nib.Nifti1Image(data, np.eye(4)), path)
    return path.read_bytes()


@pytest.mark.parametrize("name, content, words", [
    ("empty.nii.gz", b"", "is empty (0 bytes)"),
    ("empty.nrrd", b"", "is empty (0 bytes)"),
    ("empty.npy", b"", "is empty (0 bytes)"),
    # mtime 0: the same parametrize ids on every xdist worker (gzip's header holds the time)
    ("short.nii.gz", gzip.compress(b"x" * 100, mtime=0), "not a readable NIfTI"),
    ("header.nrrd", b"NRRD0004\n", "NRRD header has no"),
])
def test_empty_and_cut_headers_are_one_line(tmp_path, name, content, words):
    (tmp_path / name).write_bytes(content)
    assert_one_line_error(isoscope_here("export", tmp_path / name, "--out", tmp_path / "m.ply"), words)
    assert not (tmp_path / "m.ply").exists()


@pytest.mark.parametrize("suffix", [".nii", ".nii.gz"])
def test_a_series_cut_short_is_refused_at_its_first_time_point(tmp_path, suffix):
    whole = _series(tmp_path / "whole.nii")
    cut = whole[: len(whole) - 2 * 8 * 8 * 8 * 4]   # two of five time points gone
    path = tmp_path / f"cut{suffix}"
    path.write_bytes(gzip.compress(cut) if suffix.endswith(".gz") else cut)
    assert_one_line_error(isoscope_here("export", path, "--out", tmp_path / "m.ply"), "cut off", "10,240")
    done = isoscope_here("export", tmp_path / "whole.nii", "--out", tmp_path / "m.ply")
    assert done.returncode == 0, done.stderr

"""A compressed 4-D NIfTI is inflated once: its other time points are read from the bytes held, with no
gzip pass, while the file is unchanged (its size and modification time); a changed file is read again."""
from __future__ import annotations

import gzip
import os

import nibabel
import numpy as np
import pytest

from isoscope.volumes import VolumeError, open_volume
from isoscope.volumes.nifti_format import held


def series(n: int = 4, shape=(12, 10, 8)) -> np.ndarray:
    rng = np.random.default_rng(3)
    return rng.random(shape + (n,)).astype(np.float32) + np.arange(n, dtype=np.float32)


def write(path, data) -> None:
    nibabel.save(nibabel.Nifti1Image(data, np.diag([2.0, 2.0, 3.0, 1.0])), str(path))


@pytest.fixture(autouse=True)
def nothing_held():
    held.release()
    yield
    held.release()


def test_time_points_after_the_first_read_take_no_gzip_pass(tmp_path):
    data = series()
    path = tmp_path / "run.nii.gz"
    write(path, data)
    before = held.inflations
    first = open_volume(str(path), time=0)
    assert held.inflations == before + 1 and first.time_points == 4
    np.testing.assert_array_equal(first.data, data[..., 0])
    # Spoil the compressed bytes past the header, keeping the file's size and modification time: a read
    # that inflated the file again would fail its CRC; the held bytes give every time point.
    stat = path.stat()
    raw = bytearray(path.read_bytes())
    raw[len(raw) // 2: len(raw) // 2 + 64] = bytes(64)
    path.write_bytes(bytes(raw))
    os.utime(path, ns=(stat.st_atime_ns, stat.st_mtime_ns))
    for time in (3, 1, 2):
        volume = open_volume(str(path), time=time)
        np.testing.assert_array_equal(volume.data, data[..., time])
        assert volume.spacing == (2.0, 2.0, 3.0)
    assert held.inflations == before + 1
    # Touched (a new modification time): read from the file again, which is now corrupt, and says so.
    os.utime(path, ns=(stat.st_atime_ns, stat.st_mtime_ns + 10**9))
    with pytest.raises(VolumeError, match="corrupt|truncated|CRC|damaged"):
        open_volume(str(path), time=1)


def test_a_rewritten_file_is_read_anew(tmp_path):
    path = tmp_path / "run.nii.gz"
    write(path, series())
    open_volume(str(path), time=1)
    changed = series() * 2 + 5
    write(path, changed)
    os.utime(path, ns=(path.stat().st_atime_ns, path.stat().st_mtime_ns + 10**9))
    np.testing.assert_array_equal(open_volume(str(path), time=2).data, changed[..., 2])


def test_three_d_files_and_plain_nii_are_not_held(tmp_path):
    before = held.inflations
    write(tmp_path / "one.nii.gz", series()[..., 0])
    write(tmp_path / "plain.nii", series())
    assert open_volume(str(tmp_path / "one.nii.gz")).time_points == 1
    np.testing.assert_array_equal(open_volume(str(tmp_path / "plain.nii"), time=3).data, series()[..., 3])
    assert held.inflations == before and held.bytes_of(tmp_path / "one.nii.gz") is None


def test_a_bomb_or_a_cut_series_is_still_one_line(tmp_path):
    path = tmp_path / "cut.nii.gz"
    write(path, series())
    path.write_bytes(path.read_bytes()[:-200])
    with pytest.raises(VolumeError, match="truncated|ends early|corrupt"):
        open_volume(str(path), time=1)
    # A header claiming a small series over a stream that inflates far past it.
    header = nibabel.Nifti1Image(series(2, (4, 4, 4)), np.eye(4)).header
    with gzip.open(tmp_path / "bomb.nii.gz", "wb") as out:
        out.write(header.binaryblock + b"\0" * 4 + bytes(50 << 20))
    with pytest.raises(VolumeError, match="inflates to more"):
        open_volume(str(tmp_path / "bomb.nii.gz"), time=1)

"""DICOM series from folders: real files written here with pydicom, read back through isoscope."""
from __future__ import annotations

import numpy as np
import pytest
from support.command import isoscope_here
from support.dicom_series import NORMAL, ct_ball, write_series

import isoscope
from isoscope.volumes import VolumeError, open_volume


@pytest.mark.parametrize("step", [2.5, -2.5])  # slice positions going either way along the normal
def test_an_oblique_series_is_sorted_along_its_normal_and_rescaled_to_hounsfield(tmp_path, step):
    stored = ct_ball()
    stored[0, 0, 0] = 7            # marks the first slice written
    write_series(tmp_path / "ct", stored, step=step)
    volume = open_volume(str(tmp_path / "ct"))
    # Sorted by position along the normal: written order when the step is positive, reversed otherwise.
    expected = (stored if step > 0 else stored[::-1]).astype(np.float32) - 1024
    np.testing.assert_array_equal(volume.data, expected)
    assert volume.spacing == pytest.approx((2.5, 0.8, 0.6))
    assert volume.data.min() == -1017 and volume.data.max() == 500    # Hounsfield units
    assert any("DICOM series" in note for note in volume.notes)


def test_the_surface_of_a_dicom_ball_has_its_size_in_millimetres(tmp_path):
    write_series(tmp_path / "ct", ct_ball(slices=16, rows=32, cols=36))
    volume = open_volume(str(tmp_path / "ct"))
    verts, faces, _, _ = isoscope.marching_cubes(volume.checked, -250.0, spacing=volume.spacing, backend="cpu")
    centre = verts.mean(axis=0)
    radius = np.linalg.norm(verts - centre, axis=1)
    assert radius.mean() == pytest.approx(9.0, abs=1.0)   # mm, across anisotropic voxels


def test_uncompressed_integers_without_a_rescale_stay_integers(tmp_path):
    write_series(tmp_path / "mr", ct_ball(), intercept=0.0)
    assert open_volume(str(tmp_path / "mr")).data.dtype == np.int16


def test_several_series_are_listed_and_one_is_picked_by_number_or_uid(tmp_path):
    first = write_series(tmp_path / "study", ct_ball(), number=1, description="soft tissue")
    second = write_series(tmp_path / "study", ct_ball()[:, ::2, ::2], number=2, description="bone")
    with pytest.raises(VolumeError) as err:
        open_volume(str(tmp_path / "study"))
    message = str(err.value)
    assert "2 DICOM series" in message and first in message and second in message and "--series" in message
    assert open_volume(str(tmp_path / "study"), series="2").data.shape == (12, 10, 12)
    assert open_volume(str(tmp_path / "study"), series=first).data.shape == (12, 20, 24)
    with pytest.raises(VolumeError, match="no series '7'"):
        open_volume(str(tmp_path / "study"), series="7")


@pytest.mark.parametrize("positions, words", [
    ([0, 1, 2, 3, 5, 6, 7], "missing slice between slices 4 and 5"),
    ([0, 1, 2, 3, 3.6, 4.6, 5.6], "uneven slice spacing"),
    ([0, 1, 2, 2, 3], "share a position"),
])
def test_gaps_and_duplicates_are_refused_with_the_fix(tmp_path, positions, words):
    stored = ct_ball(slices=len(positions))
    write_series(tmp_path / "ct", stored, positions=[np.array((1.0, 2.0, 3.0)) + 2.5 * p * NORMAL for p in positions])
    with pytest.raises(VolumeError) as err:
        open_volume(str(tmp_path / "ct"))
    assert words in str(err.value) and "\n" not in str(err.value)


def test_mixed_image_sizes_are_refused(tmp_path):
    uid = write_series(tmp_path / "ct", ct_ball(slices=4))
    write_series(tmp_path / "ct" / "more", ct_ball(slices=2, rows=10), series_uid=uid, origin=(0.0, 0.0, 150.0))
    with pytest.raises(VolumeError, match="mixes image sizes"):
        open_volume(str(tmp_path / "ct"))


def test_a_compressed_series_without_a_decoder_names_the_package_to_install(tmp_path):
    write_series(tmp_path / "ls", ct_ball(slices=3), transfer_syntax="1.2.840.10008.1.2.4.80")  # JPEG-LS
    with pytest.raises(VolumeError) as err:
        open_volume(str(tmp_path / "ls"))
    assert "JPEG-LS" in str(err.value) and "pip install pylibjpeg" in str(err.value)


def test_a_folder_without_dicom_and_series_on_a_file_are_one_line_errors(tmp_path):
    (tmp_path / "empty").mkdir()
    (tmp_path / "empty" / "readme.txt").write_text("hello")
    with pytest.raises(VolumeError, match="no DICOM images"):
        open_volume(str(tmp_path / "empty"))
    np.save(tmp_path / "a.npy", np.arange(27.0).reshape(3, 3, 3))
    with pytest.raises(VolumeError, match="--series"):
        open_volume(str(tmp_path / "a.npy"), series="1")


@pytest.mark.gl
def test_the_command_line_renders_a_dicom_folder_and_picks_a_series(tmp_path):
    write_series(tmp_path / "study", ct_ball(), number=1)
    write_series(tmp_path / "study", ct_ball(), number=2)
    run = ["render", tmp_path / "study", "--iso", "-200", "--size", "160x120", "--out", tmp_path / "shot.png"]
    refused = isoscope_here(*run)   # the command in this process: what it draws and says
    assert refused.returncode == 2 and "--series" in refused.stderr and refused.stderr.count("\n") == 1
    done = isoscope_here(*run, "--series", "2")
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "shot.png").stat().st_size > 0

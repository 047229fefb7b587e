"""A DICOM folder holding a temporal series (issue 27): several acquisitions of the same slices, written here
with pydicom, open as a series of time points ordered by TemporalPositionIdentifier, AcquisitionNumber or
TriggerTime; a time point is the 3-D series of its own slices."""
from __future__ import annotations

import numpy as np
import pytest
from pydicom import dcmread
from support.command import assert_one_line_error, isoscope_here
from support.dicom_series import ct_ball, write_series

import isoscope as api
from isoscope.volumes import VolumeError, open_volume

TIMES = 3
SERIES_UID = "1.2.826.0.1.3680043.8.498.27"


def frame(t: int) -> np.ndarray:
    """Time point t: the CT ball moved t columns along."""
    return np.roll(ct_ball(), 2 * t, axis=2)


def write_temporal(folder, keyword: str, value=lambda t: t + 1, times=TIMES, skip=None):
    """One sub-folder of slices per time point, one series UID, `keyword` set to value(t) on each slice;
    `skip`: a time point left one slice short."""
    for t in range(times):
        stored = frame(t)
        write_series(folder / f"t{t}", stored, series_uid=SERIES_UID)
        for path in sorted((folder / f"t{t}").glob("*.dcm")):
            dataset = dcmread(path)
            setattr(dataset, keyword, value(t))
            dataset.save_as(path)
    if skip is not None:
        sorted((folder / f"t{skip}").glob("*.dcm"))[0].unlink()


@pytest.mark.parametrize("keyword, value", [("TemporalPositionIdentifier", lambda t: t + 1),
                                            ("AcquisitionNumber", lambda t: 10 - t),   # later number, earlier time
                                            ("TriggerTime", lambda t: 40.0 * t)])
def test_a_temporal_dicom_series_has_its_time_points_in_order(tmp_path, keyword, value):
    write_temporal(tmp_path / "cine", keyword, value)
    order = sorted(range(TIMES), key=value)
    for index, t in enumerate(order):
        volume = open_volume(str(tmp_path / "cine"), time=index)
        assert volume.time_points == TIMES
        alone = open_volume(str(tmp_path / "cine" / f"t{t}"))
        assert alone.time_points == 1
        np.testing.assert_array_equal(volume.data, alone.data)
        assert volume.spacing == pytest.approx(alone.spacing)
        np.testing.assert_allclose(volume.world[0], alone.world[0])
    assert any(keyword in note for note in volume.notes)


def test_a_time_points_mesh_equals_the_3d_series_mesh(tmp_path):
    write_temporal(tmp_path / "cine", "TemporalPositionIdentifier")
    volume = open_volume(str(tmp_path / "cine"), time=2)
    alone = open_volume(str(tmp_path / "cine" / "t2"))
    verts, faces = api.marching_cubes(volume.checked, -250.0, spacing=volume.spacing, backend="cpu")[:2]
    alone_verts, alone_faces = api.marching_cubes(alone.checked, -250.0, spacing=alone.spacing, backend="cpu")[:2]
    assert len(faces) > 0
    np.testing.assert_array_equal(faces, alone_faces)
    np.testing.assert_array_equal(verts, alone_verts)


def test_bad_temporal_series_are_one_line(tmp_path):
    write_temporal(tmp_path / "cine", "TemporalPositionIdentifier", skip=1)
    with pytest.raises(VolumeError, match="time point 1 .* slices at other positions") as error:
        open_volume(str(tmp_path / "cine"))
    assert "\n" not in str(error.value)
    write_series(tmp_path / "ct", ct_ball())
    with pytest.raises(VolumeError, match="3-D"):
        open_volume(str(tmp_path / "ct"), time=1)
    write_temporal(tmp_path / "ok", "TriggerTime", lambda t: 40.0 * t)
    with pytest.raises(VolumeError, match="past the end"):
        open_volume(str(tmp_path / "ok"), time=TIMES)


def test_export_time_all_writes_a_closed_mesh_per_dicom_time_point(tmp_path):
    write_temporal(tmp_path / "cine", "AcquisitionNumber")
    result = isoscope_here("export", str(tmp_path / "cine"), "--iso", "-250", "--time", "all",
                      "--out", str(tmp_path / "ball.stl"), "--closed")
    assert result.returncode == 0, result.stderr
    written = sorted(tmp_path.glob("ball_t*.stl"))
    assert [p.name for p in written] == [f"ball_t{t:03d}.stl" for t in range(TIMES)]
    result = isoscope_here("export", str(tmp_path / "cine"), "--iso", "-250", "--time", "7", "--out",
                      str(tmp_path / "x.stl"))
    assert_one_line_error(result, "past the end")

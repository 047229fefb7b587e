"""Every file format, written by the tests or shipped in a package, opens with the right axes and spacing."""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import nibabel
import nrrd
import numpy as np
import pytest

from isoscope.cli.volume_options import add_volume_arguments, open_volume_from_args
from isoscope.resources import volumes_dir
from isoscope.volumes import open_volume

NIBABEL_DATA = Path(nibabel.__file__).parent / "tests" / "data"


@pytest.fixture
def ramp():
    """A 4x5x6 int16 array whose every value differs, so any axis mix-up shows."""
    return (np.arange(4 * 5 * 6, dtype=np.int16).reshape(4, 5, 6) * 7 - 300)


def test_npy_keeps_axes_dtype_and_integer_range(tmp_path, ramp):
    np.save(tmp_path / "v.npy", ramp)
    volume = open_volume(str(tmp_path / "v.npy"))
    assert volume.data.dtype == np.int16
    np.testing.assert_array_equal(volume.data, ramp)
    assert volume.spacing == (1.0, 1.0, 1.0) and volume.default_level is None


def test_npy_fortran_order_and_big_endian_are_read_as_values(tmp_path, ramp):
    np.save(tmp_path / "f.npy", np.asfortranarray(ramp.astype(">f4")))
    volume = open_volume(str(tmp_path / "f.npy"))
    assert volume.data.flags.c_contiguous and volume.data.dtype.isnative
    np.testing.assert_array_equal(volume.data, ramp)


def test_npz_first_array_by_default_and_a_named_one(tmp_path, ramp):
    np.savez(tmp_path / "two.npz", first=ramp, second=ramp[::-1].copy())
    first = open_volume(str(tmp_path / "two.npz"))
    np.testing.assert_array_equal(first.data, ramp)
    assert any("2 arrays" in note for note in first.notes)
    second = open_volume(f"{tmp_path / 'two.npz'}:second")
    np.testing.assert_array_equal(second.data, ramp[::-1])


def test_4d_npy_frames_are_along_axis_0(tmp_path, ramp):
    np.save(tmp_path / "t.npy", np.stack([ramp, ramp * 2]))
    volume = open_volume(str(tmp_path / "t.npy"), time=1)
    np.testing.assert_array_equal(volume.data, ramp * 2)
    assert "time point 1 of 2" in " ".join(volume.notes) and volume.time_points == 2


def test_nrrd_spacings_and_gzip(tmp_path, ramp):
    nrrd.write(str(tmp_path / "s.nrrd"), ramp, {"spacings": [0.5, 1.0, 2.0]})
    volume = open_volume(str(tmp_path / "s.nrrd"))
    np.testing.assert_array_equal(volume.data, ramp)
    assert volume.spacing == (0.5, 1.0, 2.0)

    nrrd.write(str(tmp_path / "d.nrrd"), ramp, {"encoding": "gzip", "space": "left-posterior-superior",
                                               "space directions": np.diag([0.25, 0.5, 3.0])})
    volume = open_volume(str(tmp_path / "d.nrrd"))
    np.testing.assert_array_equal(volume.data, ramp)
    assert volume.spacing == pytest.approx((0.25, 0.5, 3.0))


def test_nhdr_with_a_detached_data_file(tmp_path, ramp):
    ramp.ravel(order="F").astype(">i2").tofile(tmp_path / "d.raw")
    (tmp_path / "d.nhdr").write_text("NRRD0004\ntype: short\ndimension: 3\nsizes: 4 5 6\n"
                                     "spacings: 1 1 2.5\nencoding: raw\nendian: big\ndata file: d.raw\n")
    volume = open_volume(str(tmp_path / "d.nhdr"))
    np.testing.assert_array_equal(volume.data, ramp)
    assert volume.spacing == (1.0, 1.0, 2.5)


def test_nrrd_4d_picks_the_non_spatial_axis(tmp_path, ramp):
    nrrd.write(str(tmp_path / "t.nrrd"), np.stack([ramp, -ramp], axis=-1),
               {"kinds": ["domain", "domain", "domain", "list"]})
    np.testing.assert_array_equal(open_volume(str(tmp_path / "t.nrrd"), time=1).data, -ramp)


def test_nifti_scan_shipped_with_nibabel():
    path = NIBABEL_DATA / "anatomical.nii"
    volume = open_volume(str(path))
    reference = nibabel.load(str(path))
    assert volume.data.shape == reference.shape == (33, 41, 25)
    assert volume.data.dtype == np.int16  # integer data keeps its type and range
    assert volume.value_range == (float(reference.get_fdata().min()), float(reference.get_fdata().max()))
    assert volume.spacing == tuple(float(z) for z in reference.header.get_zooms())


def test_nifti_4d_frame_selection_on_the_shipped_example():
    path = NIBABEL_DATA / "example4d.nii.gz"
    reference = np.asarray(nibabel.load(str(path)).dataobj)
    default = open_volume(str(path))
    assert "showing time point 0 of 2 (use --time N)" in default.notes[0]
    np.testing.assert_array_equal(default.data, reference[..., 0])
    np.testing.assert_array_equal(open_volume(str(path), time=1).data, reference[..., 1])
    assert default.spacing == pytest.approx((2.0, 2.0, 2.2), rel=1e-5)


def test_nifti_written_by_the_test_with_scaling(tmp_path, ramp):
    image = nibabel.Nifti1Image(ramp, np.diag([1.5, 2.0, 2.5, 1.0]))
    image.header.set_slope_inter(0.5, 10.0)
    nibabel.save(image, str(tmp_path / "s.nii.gz"))
    volume = open_volume(str(tmp_path / "s.nii.gz"))
    np.testing.assert_allclose(volume.data, ramp * 0.5 + 10.0)
    assert volume.spacing == (1.5, 2.0, 2.5)


def test_raw_is_x_fastest_with_flags(tmp_path, ramp):
    # x fastest: the file is the array in Fortran order.
    ramp.ravel(order="F").astype("<i2").tofile(tmp_path / "v.raw")
    volume = open_volume(str(tmp_path / "v.raw"), dims=(4, 5, 6), dtype="int16", spacing=(1, 2, 3))
    np.testing.assert_array_equal(volume.data, ramp)
    assert volume.spacing == (1.0, 2.0, 3.0)


def test_raw_big_endian(tmp_path, ramp):
    ramp.ravel(order="F").astype(">i2").tofile(tmp_path / "b.raw")
    volume = open_volume(str(tmp_path / "b.raw"), dims=(4, 5, 6), dtype="int16", endian="big")
    np.testing.assert_array_equal(volume.data, ramp)


def test_raw_sidecar_and_flags_override_it(tmp_path, ramp):
    ramp.ravel(order="F").astype("<i2").tofile(tmp_path / "s.raw")
    (tmp_path / "s.raw.json").write_text(json.dumps({"dims": [4, 5, 6], "dtype": "int16", "spacing": [2, 2, 4]}))
    volume = open_volume(str(tmp_path / "s.raw"))
    np.testing.assert_array_equal(volume.data, ramp)
    assert volume.spacing == (2.0, 2.0, 4.0)
    assert open_volume(str(tmp_path / "s.raw"), spacing=(1, 1, 1)).spacing == (1.0, 1.0, 1.0)


def test_spacing_flag_overrides_a_header_and_says_so(tmp_path, ramp):
    nrrd.write(str(tmp_path / "s.nrrd"), ramp, {"spacings": [0.5, 1.0, 2.0]})
    volume = open_volume(str(tmp_path / "s.nrrd"), spacing=(3, 3, 3))
    assert volume.spacing == (3.0, 3.0, 3.0)
    assert any("overrides" in note for note in volume.notes)


SHIPPED = ["bucky.raw", "torus.nrrd", "frames.nii.gz", "gyroid.npy", "shapes.npz"]


@pytest.mark.parametrize("name", SHIPPED)
def test_every_shipped_sample_opens(name):
    assert (volumes_dir() / name).is_file()
    volume = open_volume(f"sample:{name}")
    assert volume.data.ndim == 3 and volume.data.min() < volume.data.max()


def test_cli_flags_reach_the_loader(tmp_path, ramp):
    parser = argparse.ArgumentParser()
    parser.add_argument("volume")
    add_volume_arguments(parser)
    ramp.ravel(order="F").astype(">i2").tofile(tmp_path / "v.raw")
    args = parser.parse_args([str(tmp_path / "v.raw"), "--dims", "4", "5", "6", "--dtype", "int16",
                              "--endian", "big", "--spacing", "1", "1", "2"])
    volume = open_volume_from_args(args.volume, args)
    np.testing.assert_array_equal(volume.data, ramp)
    assert volume.spacing == (1.0, 1.0, 2.0)
    args = parser.parse_args(["sphere", "--resolution", "12"])
    assert open_volume_from_args(args.volume, args).data.shape == (12, 12, 12)


def test_progress_is_reported_while_reading_a_raw_file(tmp_path, monkeypatch):
    from isoscope.volumes import raw_format as raw
    data = np.arange(64 * 64 * 64, dtype=np.float32).reshape(64, 64, 64)
    data.ravel(order="F").tofile(tmp_path / "p.raw")
    monkeypatch.setattr(raw, "_READ_CHUNK", 1 << 16)  # 16 reads instead of one, to see progress move
    calls = []
    open_volume(str(tmp_path / "p.raw"), dims=(64, 64, 64), dtype="float32",
                progress=lambda fraction, message: calls.append((fraction, message)))
    fractions = [f for f, m in calls if m.startswith("reading")]
    assert len(fractions) >= 16 and fractions == sorted(fractions) and fractions[-1] == 1.0


@pytest.fixture
def small_slabs(monkeypatch):
    """Read 4 KiB at a time, so small test files take the slab path big files take."""
    from isoscope.volumes import npy_format, reading
    monkeypatch.setattr(reading, "SLAB_BYTES", 4096)
    monkeypatch.setattr(npy_format, "SLAB_BYTES", 4096)


@pytest.mark.parametrize("order", ["C", "F"])
def test_big_npy_is_read_in_slabs_with_progress(tmp_path, small_slabs, order):
    data = np.random.default_rng(1).random((16, 12, 10)).astype(np.float32)
    np.save(tmp_path / "b.npy", np.asarray(data, order=order))
    calls = []
    volume = open_volume(str(tmp_path / "b.npy"), progress=lambda f, m: calls.append(f))
    np.testing.assert_array_equal(volume.data, data)
    assert len(calls) > 3 and calls == sorted(calls) and calls[-1] == 1.0


def test_nifti_is_read_in_z_slabs_with_progress(small_slabs):
    path = NIBABEL_DATA / "example4d.nii.gz"
    calls = []
    volume = open_volume(str(path), time=1, progress=lambda f, m: calls.append(f))
    np.testing.assert_array_equal(volume.data, np.asarray(nibabel.load(str(path)).dataobj)[..., 1])
    assert len(calls) > 3 and calls == sorted(calls) and calls[-1] == 1.0


def test_sample_names_lists_every_shipped_volume_and_nothing_else():
    from isoscope.volumes import sample_names
    assert sample_names() == sorted(f"sample:{name}" for name in SHIPPED)  # no sidecars, scripts, notes

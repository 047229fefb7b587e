"""`isoscope measure` in the length unit a file states: an OME-Zarr image's axes in micrometres, a NIfTI's
xyzt_units in microns, an NRRD's space units, converted to mm, mm^2 and mL (the JSON's `unit` names the file's);
files that state millimetres or nothing measure as before, and the exported mesh keeps the file's own units."""
from __future__ import annotations

import json
import math

import nibabel
import nrrd
import numpy as np
import pytest
import trimesh
from support.command import isoscope_here
from support.ome_zarr import SPACE_AXES, write_ome

N, R_SAMPLES, S = 41, 12.0, 0.5   # a ball of radius 12 samples in a 41^3 grid; 0.5 file units a sample


def ball(n=N, radius=R_SAMPLES):
    i = np.arange(n, dtype=np.float64) - (n - 1) / 2
    x, y, z = np.meshgrid(i, i, i, indexing="ij")
    return (radius - np.sqrt(x * x + y * y + z * z)).astype(np.float32)


def run(path, *args):
    """`isoscope measure PATH --iso 0 ARGS`, which must succeed: its CompletedProcess."""
    result = isoscope_here("measure", path, "--iso", "0", *args)
    assert result.returncode == 0, result.stderr
    return result


def measured(path, *args):
    """The rows of `isoscope measure PATH --iso 0 ARGS --json`."""
    return json.loads(run(path, *args, "--json").stdout)


def ome(path, units):
    """The ball as an OME-Zarr image of scale S, its z, y, x axes stating `units` (None: no unit key)."""
    axes = [dict(a, **({} if u is None else {"unit": u})) for a, u in zip(SPACE_AXES, units)]
    write_ome(path, [ball()], [[S] * 3], axes=axes)
    return path


def assert_scaled(record, plain, f):
    """`record` is `plain` (the same surface measured in the file's units) with lengths times `f`."""
    assert record["area_mm2"] == pytest.approx(plain["area_mm2"] * f ** 2, rel=1e-12)
    for key in ("volume_ml", "largest_component_ml"):
        assert record[key] == pytest.approx(plain[key] * f ** 3, rel=1e-12)
    for key in ("bbox_min", "bbox_max"):
        assert record[key] == pytest.approx([v * f for v in plain[key]], rel=1e-12)
    assert (record["components"], record["euler"], record["genus"]) == (plain["components"], plain["euler"],
                                                                          plain["genus"])


def test_an_ome_zarr_in_micrometres_is_measured_in_millimetres(tmp_path):
    (record,) = measured(ome(tmp_path / "um.ome.zarr", ["micrometer"] * 3), "--json")
    (plain,) = measured(ome(tmp_path / "plain.ome.zarr", [None] * 3), "--json")
    assert record["unit"] == "micrometer" and plain["unit"] is None
    assert_scaled(record, plain, 1e-3)
    radius_mm = R_SAMPLES * S * 1e-3
    assert record["area_mm2"] == pytest.approx(4 * math.pi * radius_mm ** 2, rel=0.01)
    assert record["volume_ml"] == pytest.approx(4 / 3 * math.pi * radius_mm ** 3 * 1e-3, rel=0.01)
    text = run(tmp_path / "um.ome.zarr").stdout.splitlines()
    assert text[0] == "note: um.ome.zarr's lengths are in micrometer: converted to mm, mm^2 and mL"
    assert sum("converted" in line for line in text) == 1 and "area 0.000" in text[1]


def test_the_exported_mesh_keeps_the_file_s_units(tmp_path):
    path = ome(tmp_path / "um.ome.zarr", ["micrometer"] * 3)
    assert isoscope_here("export", path, "--iso", "0", "--out", tmp_path / "um.stl").returncode == 0
    mesh = trimesh.load(tmp_path / "um.stl", force="mesh")
    (plain,) = measured(ome(tmp_path / "plain.ome.zarr", [None] * 3), "--json")
    assert mesh.area == pytest.approx(plain["area_mm2"], rel=1e-5)   # micrometres^2, as the file's frame
    assert mesh.bounds[1] - mesh.bounds[0] == pytest.approx(np.subtract(plain["bbox_max"], plain["bbox_min"]),
                                                              rel=1e-5)


@pytest.mark.parametrize("units, words", [
    (["micrometer", "micrometer", "nanometer"], "not one length unit for all three"),
    (["micrometer", "pixel", "micrometer"], "not a length unit isoscope knows"),
])
def test_mixed_or_unknown_units_are_taken_as_millimetres_with_a_note(tmp_path, units, words):
    path = ome(tmp_path / "odd.ome.zarr", units)
    result = run(path, "--json")
    (record,) = json.loads(result.stdout)
    (plain,) = measured(ome(tmp_path / "plain.ome.zarr", [None] * 3), "--json")
    assert record["unit"] is None and record["area_mm2"] == plain["area_mm2"]
    (line,) = result.stderr.splitlines()
    assert line.startswith("note: odd.ome.zarr: its spatial axes' units") and words in line
    assert "lengths are taken as millimetres" in line


def _nifti(path, unit):
    image = nibabel.Nifti1Image(ball(), np.diag([S, S, S, 1.0]))
    image.header.set_xyzt_units(xyz=unit)
    nibabel.save(image, path)
    return path


def test_a_nifti_in_microns_is_converted_and_one_in_mm_is_as_before(tmp_path):
    (micron,) = measured(_nifti(tmp_path / "um.nii", "micron"), "--json")
    (mm,) = measured(_nifti(tmp_path / "mm.nii", "mm"), "--json")
    (unknown,) = measured(_nifti(tmp_path / "unknown.nii", "unknown"), "--json")
    assert (micron["unit"], mm["unit"], unknown["unit"]) == ("micron", "millimeter", None)
    assert_scaled(micron, mm, 1e-3)
    assert dict(mm, unit=None) == unknown   # millimetres: the very numbers of a file that states nothing
    assert "note" not in run(tmp_path / "mm.nii").stdout


def test_an_nrrd_s_space_units_are_converted(tmp_path):
    header = {"space dimension": 3, "space directions": np.eye(3) * S, "space origin": [0.0, 0.0, 0.0]}
    nrrd.write(str(tmp_path / "um.nrrd"), ball(), dict(header, **{"space units": ["um"] * 3}))
    nrrd.write(str(tmp_path / "plain.nrrd"), ball(), header)
    (um,) = measured(tmp_path / "um.nrrd", "--json")
    (plain,) = measured(tmp_path / "plain.nrrd", "--json")
    assert (um["unit"], plain["unit"]) == ("micrometer", None)
    assert_scaled(um, plain, 1e-3)


def test_npy_states_no_unit(tmp_path):
    np.save(tmp_path / "ball.npy", ball())
    result = run(tmp_path / "ball.npy", "--json", "--spacing", str(S), str(S), str(S))
    (record,) = json.loads(result.stdout)
    assert record["unit"] is None
    assert record["area_mm2"] == pytest.approx(4 * math.pi * (R_SAMPLES * S) ** 2, rel=0.01)
    assert result.stderr == ""


def test_spacing_given_is_millimetres_whatever_the_file_says(tmp_path):
    path = ome(tmp_path / "um.ome.zarr", ["micrometer"] * 3)
    result = run(path, "--json", "--spacing", str(S), str(S), str(S))
    (record,) = json.loads(result.stdout)
    (plain,) = measured(ome(tmp_path / "plain.ome.zarr", [None] * 3), "--json")
    assert record["unit"] is None and record["area_mm2"] == pytest.approx(plain["area_mm2"], rel=1e-12)


def test_a_nibabel_image_handed_to_python_keeps_its_unit(tmp_path):
    """isoscope.view / render / isosurface take a nibabel image as well as its file: the Measure section measured
    the image 10^6 larger than the file (as_volume read no unit).  A spacing given is taken as mm, as --spacing."""
    from isoscope.viewer.model.measure import Measurements
    from isoscope.viewer.model.state import ViewerState
    from isoscope.volumes import open_volume
    from isoscope.volumes.inputs import as_volume
    data = np.zeros((20, 20, 20), np.float32)
    data[5:15, 5:15, 5:15] = 1.0
    image = nibabel.Nifti1Image(data, np.diag([0.5, 0.5, 0.5, 1.0]))
    image.header.set_xyzt_units("micron")
    nibabel.save(image, tmp_path / "um.nii")
    from_file, from_image = open_volume(str(tmp_path / "um.nii")), as_volume(nibabel.load(tmp_path / "um.nii"))
    assert from_file.length_unit == from_image.length_unit == "micron"
    areas = []
    for volume in (from_file, from_image):
        state, measurements = ViewerState(), Measurements()
        state.show(volume, 0.5)
        measurements.request(state, inline=True)
        measurements.poll()
        areas.append(measurements.records[0].area_mm2)
    assert areas[0] == areas[1] and 0 < areas[0] < 1e-3    # ~1.5e-4 mm^2 (a 5 um cube), not 150 "mm^2"
    assert as_volume(nibabel.load(tmp_path / "um.nii"), spacing=(1.0, 1.0, 1.0)).length_unit is None

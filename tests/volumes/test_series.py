"""Series (issue 27, first slice): 4-D files of every format are a time axis; `--time N` (alias `--frame N`)
picks a point, export's `--time all` / `A:B` writes one mesh per point, and past the end is one line."""
from __future__ import annotations

import nibabel
import nrrd
import numpy as np
import pytest
import tifffile
import trimesh
import zarr
from support.command import assert_one_line_error
from support.command import isoscope_here as run

import isoscope
from isoscope.volumes import open_volume

N, TIMES = 18, 3
RADII = (0.45, 0.6, 0.75)


def balls() -> np.ndarray:
    """(T, N, N, N) float32: a ball growing with time, off centre so that axis order shows."""
    axis = np.linspace(-1, 1, N, dtype=np.float32)
    x, y, z = np.meshgrid(axis, axis, axis, indexing="ij")
    distance = np.sqrt((x - 0.15) ** 2 + y ** 2 + (z + 0.1) ** 2)
    return np.stack([r - distance for r in RADII]).astype(np.float32)


# Each writer: (4-D series, 3-D volume) -> two files, as its format holds a time series and one volume.
def write_nifti(folder, series, volume):
    nibabel.save(nibabel.Nifti1Image(np.moveaxis(series, 0, -1), np.eye(4)), folder / "s.nii.gz")
    nibabel.save(nibabel.Nifti1Image(volume, np.eye(4)), folder / "v.nii.gz")
    return folder / "s.nii.gz", folder / "v.nii.gz"


def write_nrrd(folder, series, volume):
    nrrd.write(str(folder / "s.nrrd"), np.moveaxis(series, 0, -1), {"kinds": ["domain"] * 3 + ["time"]})
    nrrd.write(str(folder / "v.nrrd"), volume)
    return folder / "s.nrrd", folder / "v.nrrd"


def write_zarr(folder, series, volume):
    for name, data in (("s.zarr", series), ("v.zarr", volume)):
        array = zarr.open_array(str(folder / name), mode="w", shape=data.shape, dtype=data.dtype,
                                chunks=(1, 9, 9, 9)[-data.ndim:])
        array[...] = data
    return folder / "s.zarr", folder / "v.zarr"


def write_tiff(folder, series, volume):
    tifffile.imwrite(folder / "s.tif", series, imagej=True, metadata={"axes": "TZYX"})
    tifffile.imwrite(folder / "v.tif", volume, imagej=True, metadata={"axes": "ZYX"})
    return folder / "s.tif", folder / "v.tif"


def write_npy(folder, series, volume):
    np.save(folder / "s.npy", series)
    np.save(folder / "v.npy", volume)
    return folder / "s.npy", folder / "v.npy"


WRITERS = {"nifti": write_nifti, "nrrd": write_nrrd, "zarr": write_zarr, "tiff": write_tiff, "npy": write_npy}


@pytest.mark.parametrize("kind", list(WRITERS))
def test_every_format_has_a_time_axis_whose_points_mesh_as_their_3d_volumes(tmp_path, kind):
    series = balls()
    for time in range(TIMES):
        folder = tmp_path / f"t{time}"
        folder.mkdir()
        series_path, volume_path = WRITERS[kind](folder, series, series[time])
        opened = open_volume(str(series_path), time=time)
        assert opened.time_points == TIMES and open_volume(str(volume_path)).time_points == 1
        assert f"time point {time} of {TIMES}" in " ".join(opened.notes)
        one = open_volume(str(volume_path))
        ours = isoscope.marching_cubes(np.asarray(opened.data, np.float32), 0.0, spacing=opened.spacing,
                                       backend="cpu")
        theirs = isoscope.marching_cubes(np.asarray(one.data, np.float32), 0.0, spacing=one.spacing, backend="cpu")
        for a, b in zip(ours, theirs):
            np.testing.assert_array_equal(a, b)


def test_export_time_all_writes_one_closed_mesh_per_point(tmp_path):
    path = write_npy(tmp_path, balls(), balls()[0])[0]
    result = run("export", path, "--iso", "0", "--time", "all", "--out", tmp_path / "ball.stl")
    assert result.returncode == 0, result.stderr
    volumes = []
    for time in range(TIMES):
        mesh = trimesh.load(tmp_path / f"ball_t{time:03d}.stl", force="mesh")
        assert mesh.is_watertight and mesh.volume > 0
        volumes.append(mesh.volume)
    assert volumes == sorted(volumes) and volumes[0] < volumes[-1] / 2   # the ball grows
    assert not (tmp_path / "ball.stl").exists()
    # a range, and the old flag's name for one point
    assert run("export", path, "--iso", "0", "--time", "1:3", "--out", tmp_path / "r.stl").returncode == 0
    assert sorted(p.name for p in tmp_path.glob("r_t*.stl")) == ["r_t001.stl", "r_t002.stl"]
    assert run("export", path, "--iso", "0", "--frame", "2", "--out", tmp_path / "f.stl").returncode == 0
    assert (tmp_path / "f.stl").read_bytes() == (tmp_path / "ball_t002.stl").read_bytes()


@pytest.mark.parametrize("args, words", [
    (("export", "--time", "3"), ("--time 3 is past the end", "0..2")),
    (("export", "--time", "1:7"), ("--time 1:7 is past the end", "3 time points")),
    (("export", "--time", "2:1"), ("--time",)),
    (("export", "--time", "soon"), ("--time", "'all'")),
    pytest.param(("render", "--time", "all"), ("several time points", "--time N"),
                 marks=pytest.mark.gl),   # render says first that it needs a GL context
])
def test_a_time_past_the_end_or_a_range_where_one_point_is_shown_is_one_line(tmp_path, args, words):
    path = write_npy(tmp_path, balls(), balls()[0])[0]
    command, *flags = args
    assert_one_line_error(run(command, path, *flags, "--out", tmp_path / ("o.png" if command == "render" else "o.stl")),
                          *words)
    assert not list(tmp_path.glob("o*"))


def test_a_3d_file_given_a_time_is_refused(tmp_path):
    path = write_npy(tmp_path, balls(), balls()[0])[1]
    assert_one_line_error(run("export", path, "--time", "1", "--out", tmp_path / "o.stl"), "3-D", "drop --time")


def test_a_pattern_of_3d_files_is_a_series_in_natural_order(tmp_path):
    series = balls()
    for time, name in enumerate(("f_2.npy", "f_10.npy", "f_33.npy")):  # natural order: 2, 10, 33
        np.save(tmp_path / name, series[time])
    pattern = str(tmp_path / "f_*.npy")
    for time in range(TIMES):
        volume = open_volume(pattern, time=time)
        assert volume.time_points == TIMES and np.array_equal(volume.data, series[time])
    assert "series of 3 files: showing time point 1, f_10.npy" in " ".join(open_volume(pattern, time=1).notes)
    result = run("export", pattern, "--iso", "0", "--time", "all", "--out", tmp_path / "g.ply")
    assert result.returncode == 0, result.stderr
    for time in range(TIMES):
        single = run("export", tmp_path / ("f_2.npy", "f_10.npy", "f_33.npy")[time], "--iso", "0",
                     "--out", tmp_path / f"one{time}.ply")
        assert single.returncode == 0
        assert (tmp_path / f"g_t{time:03d}.ply").read_bytes() == (tmp_path / f"one{time}.ply").read_bytes()


def test_a_series_of_mixed_shapes_or_no_files_is_one_line(tmp_path):
    np.save(tmp_path / "m_0.npy", balls()[0])
    np.save(tmp_path / "m_1.npy", balls()[1][:, :, :-2])
    result = run("export", tmp_path / "m_*.npy", "--iso", "0", "--time", "all", "--out", tmp_path / "m.stl")
    assert_one_line_error(result, "time point 1 (m_1.npy)", "one shape")
    assert not (tmp_path / "m_t001.stl").exists()
    assert_one_line_error(run("export", tmp_path / "nothing_*.npy", "--out", tmp_path / "n.stl"), "no file matches")

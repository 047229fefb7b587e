"""From Python (issue 25, first slice): arrays of every kind the field holds go in (numpy, memory maps,
Zarr, dask, nibabel images, xarray DataArrays, (array, affine)); `isosurface` gives a trimesh.Trimesh in
world coordinates, `render` an RGBA array equal to the command's PNG."""
from __future__ import annotations

import dask.array as da
import nibabel
import numpy as np
import pytest
import xarray
import zarr
from PIL import Image
from support.command import isoscope_here as run

import isoscope
from isoscope.volumes import VolumeError
from isoscope.volumes.inputs import as_volume

N = 24


@pytest.fixture(scope="module")
def field():
    axis = np.linspace(-1, 1, N, dtype=np.float32)
    x, y, z = np.meshgrid(axis, axis, axis, indexing="ij")
    return (0.6 - np.sqrt((x - 0.2) ** 2 + y * y + z * z)).astype(np.float32)


def cpu_mesh(volume, **kw):
    return isoscope.isosurface(volume, 0.0, backend="cpu", **kw)


def test_every_kind_of_array_gives_the_numpy_arrays_mesh(field, tmp_path):
    reference = cpu_mesh(field)
    np.save(tmp_path / "f.npy", field)
    store = zarr.open_array(str(tmp_path / "f.zarr"), mode="w", shape=field.shape, dtype=field.dtype, chunks=(8, 8, 8))
    store[...] = field
    kinds = {"memmap": np.load(tmp_path / "f.npy", mmap_mode="r"), "zarr": store,
             "dask": da.from_array(field, chunks=8), "path": str(tmp_path / "f.npy"), "list": field.tolist()}
    for kind, volume in kinds.items():
        mesh = cpu_mesh(volume)
        assert np.array_equal(mesh.faces, reference.faces), kind
        assert np.allclose(mesh.vertices, reference.vertices, atol=1e-6), kind
    assert as_volume(kinds["dask"]).data is kinds["dask"]   # lazy stays lazy until extracted
    assert reference.is_watertight and reference.volume > 0


def test_nibabel_images_and_affines_put_the_mesh_in_world_coordinates(field, tmp_path):
    affine = np.array([[0, -2.0, 0, 30], [1.5, 0, 0, -10], [0, 0, 1.0, 5], [0, 0, 0, 1]])  # a mirror, 2x1.5x1 mm
    image = nibabel.Nifti1Image(field, affine)
    nibabel.save(image, tmp_path / "f.nii.gz")
    from_image, from_pair, from_file = cpu_mesh(image), cpu_mesh((field, affine)), cpu_mesh(tmp_path / "f.nii.gz")
    for mesh in (from_pair, from_file):
        assert np.array_equal(mesh.faces, from_image.faces) and np.allclose(mesh.vertices, from_image.vertices)
    assert from_image.volume > 0 and from_image.is_watertight   # outward though the affine mirrors
    index = cpu_mesh(field)
    assert from_image.volume == pytest.approx(index.volume * 2 * 1.5, rel=1e-4)   # |det| of the linear part
    corner = affine @ np.array([*np.asarray(index.vertices[0]), 1.0])             # index units: spacing 1
    assert np.allclose(from_image.vertices[0], corner[:3], atol=1e-4)
    export = run("export", tmp_path / "f.nii.gz", "--iso", "0", "--out", tmp_path / "e.ply")
    assert export.returncode == 0
    import trimesh
    exported = trimesh.load(tmp_path / "e.ply", force="mesh", process=False)
    assert np.allclose(np.sort(exported.vertices, axis=0), np.sort(from_file.vertices, axis=0), atol=1e-4)


def test_a_dataarray_coordinates_give_spacing_and_origin(field):
    coords = {"x": 10 + 0.5 * np.arange(N), "y": -4 + 0.25 * np.arange(N), "z": np.arange(N, dtype=float)[::-1]}
    array = xarray.DataArray(field, dims=("x", "y", "z"), coords=coords)
    mesh, index = cpu_mesh(array), cpu_mesh(field)
    lo, hi = mesh.bounds
    ilo, ihi = index.bounds
    assert np.allclose(lo[:2], [10 + 0.5 * ilo[0], -4 + 0.25 * ilo[1]], atol=1e-4)
    assert np.allclose(hi[:2], [10 + 0.5 * ihi[0], -4 + 0.25 * ihi[1]], atol=1e-4)
    assert np.isclose(hi[2], N - 1 - ilo[2], atol=1e-4)   # z runs down: mirrored
    assert mesh.volume == pytest.approx(index.volume * 0.5 * 0.25, rel=1e-4) and mesh.is_watertight
    uneven = xarray.DataArray(field, dims=("x", "y", "z"), coords={"x": np.arange(N) ** 2.0})
    with pytest.raises(VolumeError, match="not evenly spaced"):
        as_volume(uneven)


def test_labels_come_out_coloured_and_closed():
    seg = np.zeros((16, 16, 16), np.uint8)
    seg[2:7, 2:7, 2:7], seg[8:14, 4:9, 4:9] = 1, 2
    mesh = isoscope.isosurface(seg, labels=True, backend="cpu")
    colors = np.unique(mesh.visual.vertex_colors[:, :3], axis=0)
    assert len(colors) == 2 and len(mesh.split(only_watertight=True)) == 2


@pytest.mark.parametrize("bad, words", [(np.zeros((4, 4)), "3-D"), (np.ones((4, 4, 4)), "constant"),
                                        ((np.ones((4, 4, 4)), np.eye(3)), "4x4"), ([[1, 2], [3]], "not an array")])
def test_bad_arrays_are_one_line(bad, words):
    with pytest.raises(VolumeError, match=words):
        as_volume(bad)
    with pytest.raises(VolumeError, match="4x4"):
        as_volume(np.random.default_rng(0).random((4, 4, 4)), affine=np.eye(3))


@pytest.mark.gl
def test_render_returns_the_commands_picture(field, tmp_path):
    np.save(tmp_path / "f.npy", field)
    image = isoscope.render(field, 0.0, size=(200, 150), azimuth=30)
    assert image.shape == (150, 200, 4) and image.dtype == np.uint8 and (image[..., 3] == 255).all()
    assert run("render", tmp_path / "f.npy", "--iso", "0", "--size", "200x150", "--azimuth", "30", "--out",
               tmp_path / "r.png").returncode == 0
    assert np.array_equal(image[..., :3], np.asarray(Image.open(tmp_path / "r.png").convert("RGB")))
    clear = isoscope.render(field, [0.0, 0.3], opacities=(0.4, 1.0), size=(200, 150), transparent=True)
    assert clear[0, 0, 3] == 0 and clear[75, 100, 3] > 0   # nothing at the corner, the ball in the middle
    seg = (field > 0).astype(np.uint8)
    labels = isoscope.render(seg, labels=True, size=(200, 150))
    assert labels.shape == (150, 200, 4) and len(np.unique(labels[..., :3].reshape(-1, 3), axis=0)) > 20


VIEW_SCRIPT = """
import numpy as np, isoscope
x, y, z = np.mgrid[-1:1:24j, -1:1:24j, -1:1:24j]
viewed = isoscope.view(0.6 - np.sqrt(x * x + y * y + z * z), 0.1, size=(640, 400), max_frames=5)
print(repr(viewed))
"""


@pytest.mark.gl
def test_view_opens_the_window_on_an_array_and_says_what_it_showed(x_display):
    import os
    import subprocess
    import sys
    run_view = subprocess.run([sys.executable, "-c", VIEW_SCRIPT], capture_output=True, text=True, timeout=120,
                              env=dict(os.environ, DISPLAY=x_display))
    assert run_view.returncode == 0, run_view.stderr
    assert "Viewed(level=0.1" in run_view.stdout and "levels=(0.1" in run_view.stdout
    assert "slices=(None, None, None)" in run_view.stdout
    no_display = subprocess.run([sys.executable, "-c", VIEW_SCRIPT], capture_output=True, text=True, timeout=120,
                                env={k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")})
    assert no_display.returncode == 1 and "WindowUnavailable: cannot open a window" in no_display.stderr

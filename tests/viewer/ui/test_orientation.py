"""Orientation letters (R/L, A/P, S/I) around the 3-D view, from the file's voxel-to-world transform."""
from __future__ import annotations

import nibabel
import numpy as np
import pytest

from isoscope.viewer.model.camera import OrbitCamera
from isoscope.viewer.ui.headless import HeadlessViewer
from isoscope.viewer.ui.orientation import direction_letters, screen_letters
from isoscope.volumes import open_volume


def camera_at(azimuth, elevation):
    camera = OrbitCamera()
    camera.fit((0, 0, 0), (10, 10, 10), azimuth, elevation)
    return camera


@pytest.mark.parametrize("direction, space, letters", [
    ((1, 0, 0), "RAS", "R"), ((-1, 0, 0), "RAS", "L"), ((0, 0.2, -1), "RAS", "I"),
    ((1, 0, 0), "LPS", "L"), ((0, 1, 0), "LPS", "P"), ((0, -1, 0), "LPS", "A"),
    ((0.8, -0.6, 0), "RAS", "RP"), ((-0.6, 0.8, 0.1), "LPS", "PR"),
])
def test_a_world_direction_is_named_by_its_dominant_axes(direction, space, letters):
    assert direction_letters(direction, space) == letters


def test_looking_from_the_right_in_ras_puts_anterior_on_the_right_and_superior_on_top():
    # Azimuth 0: the eye on the scene's +x (array axis 0), which an identity RAS transform calls R.
    right, up = camera_at(0, 0).screen_axes()
    letters = screen_letters((np.eye(4), "RAS"), (1, 1, 1), right, up)
    assert letters == {"right": "A", "left": "P", "top": "S", "bottom": "I"}
    # The same array in LPS (DICOM, NRRD): +y is posterior.
    assert screen_letters((np.eye(4), "LPS"), (1, 1, 1), right, up)["right"] == "P"


def test_letters_follow_an_oblique_mirrored_anisotropic_transform_read_from_a_nifti_file(tmp_path):
    turn = np.radians(30)
    rotate = np.array([[np.cos(turn), -np.sin(turn), 0], [np.sin(turn), np.cos(turn), 0], [0, 0, 1]])
    affine = np.eye(4)
    affine[:3, :3] = rotate @ np.diag([-0.8, 1.5, 2.5])    # axis 0 mirrored: index +i goes left
    path = tmp_path / "scan.nii.gz"
    nibabel.save(nibabel.Nifti1Image(np.random.default_rng(1).random((12, 10, 8)).astype(np.float32), affine), path)
    volume = open_volume(str(path))
    # Azimuth 90: the eye on scene +y, looking along -y; the screen's right is scene -x.
    right, up = camera_at(90, 0).screen_axes()
    letters = screen_letters(volume.world, volume.spacing, right, up)
    # Scene -x is index -i, which the transform sends to world rotate @ (+0.8, 0, 0) = (0.69, 0.4, 0):
    # mostly right, partly anterior.
    assert letters["right"] == "RA" and letters["left"] == "LP"
    assert letters["top"] == "S"


def test_volumes_without_a_transform_get_no_letters():
    right, up = camera_at(0, 0).screen_axes()
    assert screen_letters(None, (1, 1, 1), right, up) is None


def _bright_pixels_near_the_right_edge(volume, gl_ctx):
    viewer = HeadlessViewer((640, 400), ctx=gl_ctx)
    try:
        viewer.state.style.show_box = False
        viewer.show(volume, azimuth=0, elevation=0)
        pixels = viewer.render(panel=True)
    finally:
        viewer.release()
    # The right edge's letter sits at mid-height, within ~30 pixels of the edge; nothing else is there.
    strip = pixels[190:215, 600:635].astype(int)
    return int((strip.min(axis=-1) > 180).sum())


def test_the_letters_are_drawn_beside_the_scene_only_where_the_file_defines_them(tmp_path, gl_ctx):
    data = np.zeros((20, 20, 20), np.float32)
    data[5:15, 5:15, 5:15] = 1
    path = tmp_path / "cube.nii.gz"
    nibabel.save(nibabel.Nifti1Image(data, np.eye(4)), path)
    with_world = open_volume(str(path))
    assert _bright_pixels_near_the_right_edge(with_world, gl_ctx) > 5
    without_world = open_volume("torus")
    assert without_world.world is None
    assert _bright_pixels_near_the_right_edge(without_world, gl_ctx) == 0


def test_an_ome_zarr_world_frame_places_nothing_in_a_patient(tmp_path, gl_ctx):
    """An OME-Zarr image's scale and translation are a world frame (export, measure, the probe) in the file's
    units and z y x axes, not a patient's: no letters, no anatomical camera frame, the view buttons name the
    array axes."""
    from support.ome_zarr import write_ome

    from isoscope.viewer.model.camera import volume_frame
    from isoscope.viewer.ui.view_panel import view_names
    data = np.zeros((20, 20, 20), np.float32)
    data[5:15, 5:15, 5:15] = 1
    group = write_ome(tmp_path / "cube.ome.zarr", [data], [(1.0, 1.0, 1.0)])
    multiscales = group.attrs["multiscales"]
    multiscales[0]["datasets"][0]["coordinateTransformations"].append(
        {"type": "translation", "translation": [100.0, 20.5, -3.0]})
    group.attrs["multiscales"] = multiscales
    volume = open_volume(str(tmp_path / "cube.ome.zarr"))
    assert volume.world is not None and volume.world[1] == "OME-Zarr"
    right, up = camera_at(0, 0).screen_axes()
    assert screen_letters(volume.world, volume.spacing, right, up) is None
    assert volume_frame(volume) is None
    assert [button for button, _ in view_names(volume)] == ["-y", "+y", "+x", "-x", "+z", "-z"]
    assert _bright_pixels_near_the_right_edge(volume, gl_ctx) == 0

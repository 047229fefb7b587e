"""The panel's Measure section (issue 26): per-surface measures in the background equal to `isoscope measure`'s,
the cursor probe on a rendered sphere and on a slice, the two-click distance, and Save scene.

The measures are checked against the command run as a user runs it (its --json); the probe against the
sphere's analytic radius and the volume's own sample; the scene against a render of the saved file by the
command, pixel for pixel with the headless viewer's picture of the same state.
"""
from __future__ import annotations

import json

import numpy as np
import pytest
from support.command import isoscope_here

from isoscope.viewer.model.errors import ViewerError
from isoscope.viewer.model.measure import Measurements
from isoscope.viewer.model.state import ViewerState
from isoscope.volumes import open_volume
from isoscope.volumes.volume import finish_volume

TORUS = "volumes/torus.nrrd"
N, RADIUS = 48, 15.0
SIZE = (320, 240)


def sphere_volume(spacing=(1.0, 1.0, 1.0), length_unit=None):
    """A signed distance to a sphere of RADIUS (world units, in `length_unit`: None for mm) at the grid's centre,
    negative inside."""
    centre = (N - 1) / 2
    points = (np.indices((N, N, N)).astype(np.float32) - centre) * np.asarray(spacing, np.float32)[:, None, None, None]
    data = (np.sqrt((points ** 2).sum(axis=0)) - RADIUS).astype(np.float32)
    return finish_volume(data, spacing=spacing, name="sphere", source="sphere", gradient_direction="ascent",
                         default_level=None, length_unit=length_unit)


def command_records(*args):
    result = isoscope_here("measure", *args, "--json")
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout)


def assert_same_as_command(record, expected):
    assert record.area_mm2 == pytest.approx(expected["area_mm2"], rel=1e-9)
    assert record.volume_ml == pytest.approx(expected["volume_ml"], rel=1e-9)
    assert record.components == expected["components"]
    assert record.largest_component_ml == pytest.approx(expected["largest_component_ml"], rel=1e-9)
    assert record.bbox_min == pytest.approx(tuple(expected["bbox_min"]))
    assert record.bbox_max == pytest.approx(tuple(expected["bbox_max"]))
    assert record.open_edges == expected["open_edges"]
    assert (record.euler, record.genus, record.cavities) == (expected["euler"], expected["genus"], expected["cavities"])
    assert record.cavities_ml == pytest.approx(expected["cavities_ml"], rel=1e-9)


@pytest.mark.parametrize("closed", [False, True])
def test_measures_equal_the_command_s_on_the_same_volume_and_levels(closed):
    state = ViewerState()
    state.show(open_volume(TORUS), 0.5)
    state.levels.add(0.2)
    state.closed = closed   # the panel's 'closed at the border'
    measurements = Measurements()
    request = measurements.request(state)   # on a worker thread, as the panel asks
    while not measurements.poll(wait_s=30.0):
        pass
    assert measurements.answered_id == request and measurements.error is None
    expected = command_records(TORUS, "--iso", "0.5", "--iso", "0.2", *(["--closed"] if closed else []))
    assert [r.name for r in measurements.records] == ["level 0.5", "level 0.2"]
    for record, row in zip(measurements.records, expected):
        assert_same_as_command(record, row)
    if closed:
        assert all(r.open_edges == 0 for r in measurements.records)


def test_a_store_in_micrometres_measures_in_millimetres_as_the_command_does(tmp_path):
    """An OME-Zarr image whose axes are in micrometres: the section's records are the command's, converted
    (area x 1e-6 of the same store stating no unit, volume x 1e-9, box x 1e-3)."""
    from support.ome_zarr import SPACE_AXES, write_ome
    field = sphere_volume().data
    write_ome(tmp_path / "um.ome.zarr", [field], [[0.5] * 3], axes=[dict(a, unit="micrometer") for a in SPACE_AXES])
    write_ome(tmp_path / "plain.ome.zarr", [field], [[0.5] * 3])
    records, notes = {}, {}
    for name in ("um", "plain"):
        state = ViewerState()
        state.show(open_volume(str(tmp_path / f"{name}.ome.zarr")), 0.0)
        measurements = Measurements()
        measurements.request(state, inline=True)
        measurements.poll()
        (records[name],), notes[name] = measurements.records, measurements.note
    # the section says the conversion, as the command's note does (it said nothing)
    assert notes == {"um": "the file's lengths are in micrometer: converted to mm, mm^2 and mL", "plain": None}
    (expected,) = command_records(tmp_path / "um.ome.zarr", "--iso", "0")
    assert expected["unit"] == "micrometer"
    assert_same_as_command(records["um"], expected)
    um, plain = records["um"], records["plain"]
    assert um.area_mm2 == pytest.approx(plain.area_mm2 * 1e-6, rel=1e-12)
    assert um.volume_ml == pytest.approx(plain.volume_ml * 1e-9, rel=1e-12)
    assert um.size == pytest.approx(tuple(v * 1e-3 for v in plain.size), rel=1e-12)


def test_a_newer_request_makes_the_older_answer_stale():
    state = ViewerState()
    state.show(open_volume(TORUS), 0.5)
    measurements = Measurements()
    first = measurements.request(state)
    state.levels.set_value(0.3)
    second = measurements.request(state)
    while measurements.running is not None:
        measurements.poll(wait_s=30.0)
    assert first != second and measurements.answered_id == second
    assert [r.name for r in measurements.records] == ["level 0.3"]


def test_labels_measure_as_the_command_s_labels(tmp_path):
    labels = np.zeros((20, 18, 30), np.uint8)
    labels[0:9, 4:12, 2:10] = 1      # touches the volume's x = 0 face
    labels[10:17, 5:15, 6:14] = 2
    labels[2:9, 2:9, 18:27] = 3
    labels[4:7, 4:7, 20:25] = 0      # a hollow inside label 3: its surface's inner wall is a cavity
    path = tmp_path / "seg.npy"
    np.save(path, labels)
    state = ViewerState()
    state.show(open_volume(str(path)))
    state.show_labels()
    measurements = Measurements()
    measurements.request(state, inline=True)
    measurements.poll()
    expected = command_records(path, "--labels")
    assert [r.name for r in measurements.records] == [f"label {row['label']}" for row in expected]
    for record, row in zip(measurements.records, expected):
        assert_same_as_command(record, row)
        assert record.open_edges == 0   # a label's surface is closed at the border already
    assert [r.cavities for r in measurements.records] == [0, 0, 1]
    assert measurements.records[2].cavities_ml == pytest.approx(3 * 3 * 5 * 1e-3, rel=0.3)


def test_nothing_to_measure_is_one_line():
    measurements = Measurements()
    with pytest.raises(ViewerError, match="open a volume"):
        measurements.request(ViewerState())
    state = ViewerState()
    state.show(sphere_volume(), 0.0)
    state.levels.set_visible(0, False)
    with pytest.raises(ViewerError, match="no surface is visible"):
        measurements.request(state)


def test_two_picks_give_their_distance_and_a_third_starts_again():
    measurements = Measurements()
    measurements.pick((0.0, 0.0, 0.0))
    assert measurements.distance is None
    measurements.pick((3.0, 4.0, 12.0))
    assert measurements.distance == pytest.approx(13.0)
    measurements.pick((1.0, 1.0, 1.0))
    assert len(measurements.picks) == 1 and measurements.distance is None
    measurements.pick((4.0, 5.0, 13.0), mm_per_unit=1e-3)   # a file in micrometres: the distance in mm
    assert measurements.distance == pytest.approx(13e-3)


# --- the probe, on a real context -------------------------------------------------------------------------
@pytest.fixture
def sphere_viewer(gl_ctx):
    from isoscope.viewer.ui.headless import HeadlessViewer
    viewer = HeadlessViewer(SIZE, ctx=gl_ctx)
    viewer.show(sphere_volume(spacing=(1.0, 1.0, 1.5)), 0.0)
    yield viewer
    viewer.release()


@pytest.fixture
def picker(gl_ctx):
    from isoscope.viewer.gfx.picking import Picker
    picker = Picker(gl_ctx)
    yield picker
    picker.release()


def test_the_probe_at_a_sphere_s_centre_is_on_the_sphere(sphere_viewer, picker):
    sphere_viewer.render()
    viewport = (0, 0, *SIZE, 0)
    probe = picker.probe(sphere_viewer.scene, sphere_viewer.camera, viewport, (SIZE[0] // 2, SIZE[1] // 2))
    volume = sphere_viewer.state.volume
    centre = (np.asarray(volume.data.shape) - 1) / 2 * np.asarray(volume.spacing)
    point = np.asarray(probe.point)
    assert probe.on == "surface"
    assert abs(np.linalg.norm(point - centre) - RADIUS) < 1.0   # within a voxel of the sphere
    # on the side facing the camera
    assert np.dot(point - centre, sphere_viewer.camera.eye() - centre) > 0
    assert probe.voxel == tuple(int(v) for v in np.rint(point / np.asarray(volume.spacing)))
    assert probe.value == volume.data[probe.voxel]
    assert abs(probe.value) < 1.5   # a sample next to the level 0
    # the mark drawn for a picked point lands back on the pixel it was picked at
    from isoscope.viewer.gfx.picking import project
    assert project(sphere_viewer.camera, viewport, probe.point) == pytest.approx((SIZE[0] // 2, SIZE[1] // 2), abs=0.01)
    # the corner of the picture shows the background: nothing there
    assert picker.probe(sphere_viewer.scene, sphere_viewer.camera, viewport, (1, 1)) is None


def test_the_probe_follows_the_panel_s_lens_shift(sphere_viewer, picker):
    """With the panel covering the left, the scene centres in the rest: the pixel at that centre hits the
    sphere's front as the middle pixel did without it."""
    covered = 100
    viewport = (0, 0, *SIZE, covered)
    middle = (covered // 2 + SIZE[0] // 2, SIZE[1] // 2)
    probe = picker.probe(sphere_viewer.scene, sphere_viewer.camera, viewport, middle)
    plain = picker.probe(sphere_viewer.scene, sphere_viewer.camera, (0, 0, *SIZE, 0), (SIZE[0] // 2, SIZE[1] // 2))
    assert np.linalg.norm(np.asarray(probe.point) - np.asarray(plain.point)) < 1.0


def test_two_probes_give_the_distance_between_the_points(sphere_viewer, picker):
    viewport = (0, 0, *SIZE, 0)
    measurements = Measurements()
    for pixel in ((SIZE[0] // 2 - 15, SIZE[1] // 2), (SIZE[0] // 2 + 15, SIZE[1] // 2 + 10)):
        measurements.pick(picker.probe(sphere_viewer.scene, sphere_viewer.camera, viewport, pixel).world)
    a, b = measurements.picks
    assert measurements.distance == pytest.approx(float(np.linalg.norm(a - b)))
    assert 3.0 < measurements.distance < 2 * RADIUS


def test_the_probe_reads_a_slice_in_front_of_the_surface(sphere_viewer, picker):
    state = sphere_viewer.state
    state.levels.set_visible(0, False)   # the slice alone
    state.slices.show(0, True, N // 2)
    viewport = (0, 0, *SIZE, 0)
    probe = picker.probe(sphere_viewer.scene, sphere_viewer.camera, viewport, (SIZE[0] // 2, SIZE[1] // 2))
    assert probe.on == "slice x"
    assert probe.voxel[0] == N // 2
    assert probe.value == sphere_viewer.state.volume.data[probe.voxel]


# --- Save scene ----------------------------------------------------------------------------------------------
def test_save_scene_writes_what_render_redraws_pixel_for_pixel(gl_ctx, tmp_path):
    """The panel's Save scene, from a viewer's state and camera (two levels, one translucent, a slice, a
    turned camera): `isoscope render scene.json` draws the viewer's own picture of that state."""
    from PIL import Image

    from isoscope.viewer.model.scene_file import read_scene
    from isoscope.viewer.ui.headless import HeadlessViewer
    from isoscope.viewer.ui.measure_panel import MeasureSection
    viewer = HeadlessViewer(SIZE, ctx=gl_ctx)
    try:
        viewer.open(TORUS)
        viewer.state.levels.set_value(0.5)
        viewer.state.levels.add(0.2)
        viewer.state.levels.set_opacity(1, 0.4)
        viewer.update()
        viewer.state.slices.show(2, True, 9)
        viewer.camera.orbit(40, -25)
        expected = viewer.picture()
        section = MeasureSection()
        path = section.save_scene(viewer.state, viewer.camera, tmp_path / "torus-scene.json", size=SIZE)
        assert path is not None and viewer.state.message.startswith("scene saved")
    finally:
        viewer.release()
    scene = read_scene(path)
    assert [level["value"] for level in scene["levels"]] == [0.5, 0.2] and scene["size"] == list(SIZE)
    result = isoscope_here("render", path, "--out", tmp_path / "again.png")
    assert result.returncode == 0, result.stderr
    assert np.array_equal(np.asarray(Image.open(tmp_path / "again.png").convert("RGB")), expected)


def test_save_scene_without_a_volume_says_so(tmp_path):
    from isoscope.viewer.model.camera import OrbitCamera
    from isoscope.viewer.ui.measure_panel import MeasureSection
    state = ViewerState()
    assert MeasureSection().save_scene(state, OrbitCamera(), tmp_path / "s.json") is None
    assert "no volume on show" in state.error and not (tmp_path / "s.json").exists()


# --- in the window, under Xvfb ---------------------------------------------------------------------------------
def test_ctrl_clicks_in_the_window_probe_the_sphere_and_measure_their_distance(x_display):
    import ctypes.util
    if ctypes.util.find_library("Xtst") is None:
        pytest.skip("libXtst is not installed")
    from support.x_window import run_spawned
    run_spawned(_ctrl_clicks, x_display)


def _ctrl_clicks(x_display):
    """Ctrl held, two clicks right of the panel (XTest, through X -> GLFW -> imgui): two probes on the sphere,
    their distance in the panel's model, and the camera has not orbited."""
    import ctypes
    import ctypes.util
    import os
    import time

    os.environ["DISPLAY"] = x_display
    import glfw

    from isoscope.viewer.model.recent import RecentFiles
    from isoscope.viewer.ui.window import ViewerWindow
    # lengths in micrometres: the panel's picks give the distance in millimetres
    window = ViewerWindow(sphere_volume(length_unit="micrometer"), 0.0, size=(640, 400), recent=RecentFiles(None))
    try:
        for _ in range(3):
            window.draw_frame()
        display = glfw.get_x11_display()
        xtst = ctypes.CDLL(ctypes.util.find_library("Xtst"))
        xlib = ctypes.CDLL(ctypes.util.find_library("X11") or "libX11.so.6")
        xlib.XStringToKeysym.restype, xlib.XStringToKeysym.argtypes = ctypes.c_ulong, [ctypes.c_char_p]
        xlib.XKeysymToKeycode.restype = ctypes.c_ubyte
        xlib.XKeysymToKeycode.argtypes = [ctypes.c_void_p, ctypes.c_ulong]
        xlib.XSync.argtypes = [ctypes.c_void_p, ctypes.c_int]
        xtst.XTestFakeMotionEvent.argtypes = [ctypes.c_void_p, ctypes.c_int, ctypes.c_int, ctypes.c_int, ctypes.c_ulong]
        xtst.XTestFakeButtonEvent.argtypes = [ctypes.c_void_p, ctypes.c_uint, ctypes.c_int, ctypes.c_ulong]
        xtst.XTestFakeKeyEvent.argtypes = [ctypes.c_void_p, ctypes.c_uint, ctypes.c_int, ctypes.c_ulong]
        control = xlib.XKeysymToKeycode(display, xlib.XStringToKeysym(b"Control_L"))
        left, top = glfw.get_window_pos(window.window)

        def send(*events):
            for kind, *args in events:
                if kind == "move":
                    xtst.XTestFakeMotionEvent(display, -1, round(left + args[0]), round(top + args[1]), 0)
                elif kind == "key":
                    xtst.XTestFakeKeyEvent(display, control, args[0], 0)
                else:
                    xtst.XTestFakeButtonEvent(display, 1, kind == "press", 0)
            xlib.XSync(display, 0)
            time.sleep(0.05)
            xlib.XSync(display, 0)
            for _ in range(3):
                window.draw_frame()

        covered = window.panel.covered_width
        middle = ((640 + covered) / 2, 200)
        pose = (window.camera.azimuth, window.camera.elevation)
        measurements = window.panel.measure_section.measurements
        send(("key", True))
        for point in (middle, (middle[0] + 12, middle[1] - 8)):
            send(("move", *point))
            send(("press",), ("release",))
        send(("key", False))
        assert (window.camera.azimuth, window.camera.elevation) == pose, "a ctrl+click orbited"
        assert len(measurements.picks) == 2, measurements.picks
        centre = (N - 1) / 2
        for picked in measurements.picks:
            assert abs(np.linalg.norm(picked - centre) - RADIUS) < 1.0
        apart = float(np.linalg.norm(measurements.picks[1] - measurements.picks[0]))   # micrometres
        assert measurements.distance == pytest.approx(apart * 1e-3, rel=1e-12) and 2.0 < apart < 2 * RADIUS
        assert measurements.probe.on == "surface"
        assert len(measurements.points) == 2 and measurements.points[1] is not None
    finally:
        window.close()

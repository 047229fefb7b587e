"""The panel's Measure section: each surface's area, enclosed volume, pieces and bounding box,
measured on request in the background (model/measure.py); the cursor probe (position, voxel and value
under the cursor: ctrl+click, or live with "probe under the cursor") and the distance between the last
two ctrl+clicks (gfx/picking.py); and Save scene, which writes what `render --save-scene` writes.

Plugged into `Panel.draw` (panel.py); the window calls `pick` once a frame, after the panel's layout,
with its scene (the probe reads the meshes' depth in the window's GL context).
"""
from __future__ import annotations

from pathlib import Path

from ..model.errors import USER_ERRORS, ViewerError, one_line
from ..model.measure import Measurements
from ..model.state import ViewerState
from .file_browser import FileBrowser, default_recent_folders, has_dialog_tool
from .gui import act, imgui, section, tooltip

SCENE_FILTERS = ["Scenes", "*.json", "All files", "*"]
NOTE_COLOR = imgui.ImVec4(0.60, 0.85, 0.60, 1.0)
ERROR_COLOR = imgui.ImVec4(1.0, 0.45, 0.40, 1.0)
MARK_COLOR = imgui.ImVec4(1.0, 0.85, 0.20, 1.0)   # the picked points and their line, over the scene
MARK_RADIUS = 5.0


class MeasureSection:
    """The panel's Measure section: the surfaces' measures made in the background, the cursor probe, the two-click
    distance and Save scene."""

    def __init__(self, can_browse: bool = True):
        self.measurements = Measurements()
        self.probing = False              # probe under the cursor as it moves (else on ctrl+click only)
        self.picker = None                # gfx/picking.Picker, made on the first pick in the drawing context
        self.scene_size = (800, 600)      # the window's framebuffer: the size a saved scene renders at
        self.can_browse = can_browse
        self.browser: FileBrowser | None = None   # Save scene's, where there is no native dialog
        self._scene_dialog = None         # a pending portable_file_dialogs.save_file
        self._camera = None
        self._last_cursor = None

    # --- layout -----------------------------------------------------------------
    def draw(self, state: ViewerState, camera) -> None:
        """Lay the section out; takes the measures' answer when it comes."""
        measurements = self.measurements
        measurements.poll()
        io = imgui.get_io()   # a saved scene renders at the window's pixels
        self.scene_size = (int(io.display_size.x * io.display_framebuffer_scale.x),
                           int(io.display_size.y * io.display_framebuffer_scale.y))
        self._camera = camera
        self._collect_scene_dialog(state)
        if not section("Measure"):
            return
        running = measurements.running
        if running is not None:
            imgui.progress_bar(running.fraction, imgui.ImVec2(-1, 0), running.message)
        elif imgui.button("Measure surfaces"):
            act(state, measurements.request, state)
        tooltip("area, enclosed volume, pieces and box of each visible surface, as `isoscope measure` gives them")
        imgui.same_line()
        if not state.labels:   # a label's surface is closed at the border already (labels.py)
            state.closed = imgui.checkbox("closed at the border", state.closed)[1]
            tooltip("cap each level where it leaves the volume, drawn, saved and measured (as export --closed)")
        if measurements.error:
            imgui.text_colored(ERROR_COLOR, measurements.error)
        for record in measurements.records:
            self._record(record)
        if measurements.note:   # wrapped: the unit's note is wider than the panel
            imgui.push_text_wrap_pos(0.0)
            imgui.text_colored(NOTE_COLOR, measurements.note)
            imgui.pop_text_wrap_pos()
        self._probe_lines()
        if self.can_browse and state.volume is not None:
            if imgui.button("Save scene...") and not self._saving_scene:
                self._open_scene_dialog(state)
            tooltip("the volume, levels, colours, camera, slices and clip as a JSON file: `isoscope FILE` opens "
                    "it, `isoscope render FILE` draws it")

    @staticmethod
    def _record(record) -> None:
        if not record.components:
            imgui.text(f"{record.name}: no surface")
            return
        imgui.text(f"{record.name}")
        imgui.text(f"  area {record.area_mm2:.6g} mm^2, volume {record.volume_ml:.5g} mL")
        imgui.text(f"  {record.components:,} piece{'s' * (record.components != 1)}, largest "
                   f"{record.largest_component_ml:.5g} mL")
        if record.cavities:   # a hollow's inner walls are pieces too (measure's line names them the same way)
            imgui.text(f"  {record.cavities:,} of them {'cavities' if record.cavities != 1 else 'a cavity'}, "
                       f"{record.cavities_ml:.5g} mL")
            tooltip("pieces that enclose less than nothing: the walls of hollows inside the object")
        imgui.text(f"  Euler characteristic {record.euler}" +
                   (f", genus {record.genus}" if record.genus is not None else ""))
        tooltip("V - E + F of the mesh; genus: the handles (tunnels through the object) of a closed surface, "
                "summed over its pieces")
        imgui.text("  box " + " x ".join(f"{v:.4g}" for v in record.size) + " mm")
        if record.open_edges:
            imgui.text_colored(ERROR_COLOR, f"  open at {record.open_edges:,} edges: tick closed at the border")

    def _probe_lines(self) -> None:
        measurements = self.measurements
        self.probing = imgui.checkbox("probe under the cursor", self.probing)[1]
        tooltip("the position, voxel and value under the cursor; ctrl+click two points for their distance")
        probe = measurements.probe
        imgui.push_text_wrap_pos(0.0)
        if probe is not None:
            imgui.text(probe.line())
        else:
            imgui.text_disabled("ctrl+click the surface or a slice to probe it")
        imgui.pop_text_wrap_pos()
        if measurements.distance is not None:
            imgui.text(f"distance {measurements.distance:.5g} mm")
            imgui.same_line()
            if imgui.small_button("clear"):
                measurements.clear_picks()
        elif measurements.picks:
            imgui.text_disabled("ctrl+click a second point for the distance")

    def keys(self, camera) -> dict:
        """Characters this section answers in the window (as window.py's `_on_char` table)."""
        return {}

    # --- the probe (the window, once a frame) --------------------------------------
    def pick(self, scene, camera, covered_left: float) -> None:
        """The probe under imgui's mouse: on ctrl+click (a point for the distance too), and as it moves with
        "probe under the cursor"; not over the panel.  `covered_left`: the panel's width, imgui units."""
        self.draw_marks(camera, covered_left)
        io = imgui.get_io()
        if io.want_capture_mouse or not imgui.is_mouse_pos_valid():
            return
        cursor = (io.mouse_pos.x, io.mouse_pos.y)
        clicked = imgui.is_mouse_clicked(0) and io.key_ctrl
        if not clicked and not (self.probing and cursor != self._last_cursor):
            return
        self._last_cursor = cursor
        probe = self.probe_at(scene, camera, cursor, covered_left)
        if clicked and probe is not None:
            from ...core.units import mm_per_unit
            self.measurements.pick(probe.world, probe.point, mm_per_unit(scene.state.volume.length_unit))

    def draw_marks(self, camera, covered_left: float = 0.0) -> None:
        """The picked points over the scene (under the panel's windows), joined by a line with their distance."""
        from ..gfx.picking import project
        io = imgui.get_io()
        scale_x, scale_y = io.display_framebuffer_scale.x, io.display_framebuffer_scale.y
        width, height = int(io.display_size.x * scale_x), int(io.display_size.y * scale_y)
        viewport = (0, 0, width, height, int(covered_left * scale_x))
        marks = []
        for point in self.measurements.points:
            pixel = project(camera, viewport, point) if point is not None else None
            if pixel is not None:
                marks.append(imgui.ImVec2(pixel[0] / scale_x, (height - 1 - pixel[1]) / scale_y))
        draw_list = imgui.get_background_draw_list()
        colour = imgui.get_color_u32(MARK_COLOR)
        radius = MARK_RADIUS * imgui.get_style().font_scale_dpi
        for mark in marks:
            draw_list.add_circle(mark, radius, colour, 0, 2.0)
        distance = self.measurements.distance
        if len(marks) == 2 and distance is not None:
            draw_list.add_line(marks[0], marks[1], colour, 2.0)
            middle = imgui.ImVec2((marks[0].x + marks[1].x) / 2 + radius, (marks[0].y + marks[1].y) / 2 + radius)
            draw_list.add_text(middle, colour, f"{distance:.4g} mm")

    def probe_at(self, scene, camera, cursor, covered_left: float = 0.0):
        """The probe at `cursor` (imgui units, from the top left), kept for the panel; None off the scene."""
        io = imgui.get_io()
        scale_x, scale_y = io.display_framebuffer_scale.x, io.display_framebuffer_scale.y
        width, height = int(io.display_size.x * scale_x), int(io.display_size.y * scale_y)
        pixel = (int(cursor[0] * scale_x), height - 1 - int(cursor[1] * scale_y))
        if self.picker is None:
            from ..gfx.picking import Picker
            self.picker = Picker(scene.ctx)
        probe = self.picker.probe(scene, camera, (0, 0, width, height, int(covered_left * scale_x)), pixel)
        self.measurements.probe = probe if probe is not None else self.measurements.probe
        return probe

    def release(self) -> None:
        """Free the picker's GL objects, if a pick made one."""
        if self.picker is not None:
            self.picker.release()
            self.picker = None

    # --- Save scene ---------------------------------------------------------------
    @property
    def _saving_scene(self) -> bool:
        return self._scene_dialog is not None or (self.browser is not None and self.browser.is_open)

    def _open_scene_dialog(self, state: ViewerState) -> None:
        name = Path(state.volume.name).stem.split(".")[0] or "isoscope"
        default = Path.cwd() / f"{name}-scene.json"
        if has_dialog_tool():
            import imgui_bundle.portable_file_dialogs as pfd
            self._scene_dialog = pfd.save_file("Save scene", str(default), SCENE_FILTERS)
            return
        if self.browser is None:
            self.browser = FileBrowser(default_recent_folders())
        self.browser.save_file("Save scene", default, ["*.json"], purpose="scene")

    def _collect_scene_dialog(self, state: ViewerState) -> None:
        path = None
        if self._scene_dialog is not None and self._scene_dialog.ready(0):
            path, self._scene_dialog = self._scene_dialog.result(), None
        elif self.browser is not None:
            path = self.browser.draw()
        if path:
            self.save_scene(state, self._camera, path)

    def save_scene(self, state: ViewerState, camera, path, size=None) -> Path | None:
        """Write the scene on show to `path` (as `render --save-scene`), at `size` (default the window's);
        its path, or None with the reason in the state's error."""
        from ..model.scene_file import scene_of, write_scene
        try:
            if camera is None:
                raise ViewerError("no view to save yet")
            written = write_scene(path, scene_of(state, camera, size or self.scene_size))
        except USER_ERRORS as exc:
            state.error = f"cannot save the scene: {one_line(exc)}"
            return None
        state.error, state.message = None, f"scene saved: {written}"
        return written

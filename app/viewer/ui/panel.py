"""The imgui side panel, and the imgui context + native backends that draw it.

`ImguiLayer` owns imgui's GL objects (through imgui-bundle's C++ OpenGL3
backend, no PyOpenGL) and, in a window, its GLFW input backend; headless
renders feed it a display size instead, and scale it with their height as a
4K monitor would (`render_scale`).  `Panel` lays out the widgets and changes
the viewer only through `ViewerState` (model/state.py), whose refusals
(exceptions) it shows in one line beside the control that asked (`act`); other
errors, messages and hints go to a status line at the window's bottom, so no
control ever moves for a message.  The panel is as tall as its content, or the
window less the status line (then it scrolls).  It reads the GPU side's stats
from the scene but changes nothing there, so laying it out extracts nothing.
"""
from __future__ import annotations

from pathlib import Path

from ...volumes import builtin_names
from ..model.formats import level_format, level_text
from ..model.hints import empty_level_hint
from ..model.histogram import fraction_of, level_at
from ..model.pacing import pace_text
from ..model.raycast import rays_line, rays_note, surfaces_drawn
from ..model.settings import PanelSettings
from ..model.state import ViewerState
from . import gui
from .file_browser import FileBrowser, default_recent_folders, has_dialog_tool, patterns_of
from .gui import act, choose, imgui, px, refusal, remember_sections, section, tooltip
from .labels_panel import LabelsSection
from .levels_panel import LevelsSection
from .measure_panel import MeasureSection
from .mesh_panel import MeshSection
from .orientation import draw_orientation
from .slice_panel import SlicePanel
from .time_panel import TimeSection
from .view_panel import ViewSection

PANEL_TITLE = "isoscope"
PANEL_WIDTH = 330
PANEL_HOME = (8.0, 8.0)     # top-left corner, imgui units
PANEL_LEFT_SLACK = 24.0     # a panel this close to its home's x still counts as covering the left
PANEL_KEEP_VISIBLE = 64.0   # of the panel's width, kept inside the window with its whole title bar
PANEL_MIN_HEIGHT = 120.0    # however short the window, the panel keeps this much (and scrolls)
MARGIN = 8.0                # between the panel, the status line and the window's edges
HISTOGRAM_HEIGHT = 56.0
EXACT_WIDTH = 84.0          # the typed level beside the iso slider
REFUSAL_WIDTH = 300.0       # a refusal's note beside the panel wraps at this width
STATUS_TITLE = "##status"
REFUSAL_TITLE = "##refusal"
FLOATING = (imgui.WindowFlags_.no_decoration | imgui.WindowFlags_.no_saved_settings | imgui.WindowFlags_.no_nav
            | imgui.WindowFlags_.no_focus_on_appearing | imgui.WindowFlags_.no_move)
HINT_COLOR = imgui.ImVec4(0.95, 0.75, 0.35, 1.0)
ERROR_COLOR = imgui.ImVec4(1.0, 0.45, 0.40, 1.0)
NOTE_COLOR = imgui.ImVec4(0.60, 0.85, 0.60, 1.0)
VOLUME_FILE_FILTERS = ["Volumes and scenes",
                       "*.npy *.npz *.nii *.nii.gz *.nrrd *.nhdr *.raw *.vol *.mhd *.tif *.tiff *.json",
                       "All files", "*"]
MESH_FILE_FILTERS = ["Meshes", "*.stl *.ply *.obj *.glb *.off", "All files", "*"]
EXPR_HINT = "x^2 + y^2 + z^2 - 0.5"   # the volumes grammar; inside is where it is < 0


def render_scale(height: int) -> float:
    """The panel's scale in a headless render `height` pixels tall: as a monitor of that height would set it
    (1 up to 1080 rows, 2 at 2160: 4K), in quarter steps."""
    return max(1.0, round(4 * height / 1080) / 4)


def shown_notes(state: ViewerState) -> list[str]:
    """The volume's notes the panel shows: a series' "showing time point i of n (use --time N)" left out, as
    the Time section's slider and label say which time point is drawn (the note went stale as time moved)."""
    from ...volumes.time_points import TimeNote
    return [note for note in state.volume.notes if not (state.series.active and isinstance(note, TimeNote))]


class ImguiLayer:
    """imgui's context and its OpenGL backend, with the GLFW input backend in a window or a given display size headless.
    """

    def __init__(self, glfw_window_address: int | None = None):
        """With a GLFW window's address, imgui reads that window's input; without, it is headless (and
        scaled by its first frame's height, `render_scale`)."""
        self.context = imgui.create_context()
        self.scale = None
        imgui.get_io().set_ini_filename("")  # no imgui.ini littering the working directory
        self._has_window = glfw_window_address is not None
        if self._has_window:
            # install_callbacks=True chains to callbacks set on the window before this call.
            imgui.backends.glfw_init_for_opengl(glfw_window_address, True)
        imgui.backends.opengl3_init("#version 410")  # 4.1 core (macOS) and newer

    def new_frame(self, display_size: tuple[int, int] | None = None, dt_seconds: float = 1 / 60) -> None:
        """Start an imgui frame: the window's input and size, or headless `display_size` and `dt_seconds` (the scale set
        from the first frame's height)."""
        imgui.set_current_context(self.context)
        imgui.backends.opengl3_new_frame()
        if self._has_window:
            imgui.backends.glfw_new_frame()
        else:
            io = imgui.get_io()
            io.display_size = imgui.ImVec2(*display_size)
            if self.scale is None:
                self.set_scale(render_scale(display_size[1]))
            io.delta_time = max(dt_seconds, 1e-4)
        imgui.new_frame()

    def set_scale(self, scale: float) -> None:
        """Sizes and fonts `scale` times imgui's (a monitor's content scale), between frames: again when
        the window moves to a monitor of another scale."""
        imgui.set_current_context(self.context)
        style = imgui.get_style()
        factor = float(scale) / (self.scale or 1.0)
        if factor != 1.0:
            style.scale_all_sizes(factor)
        style.font_scale_dpi = self.scale = float(scale)

    def render(self) -> None:
        """Draw this frame's widgets into the framebuffer that is bound now."""
        imgui.render()
        imgui.backends.opengl3_render_draw_data(imgui.get_draw_data())

    def shutdown(self) -> None:
        """Free imgui's backends and destroy its context."""
        imgui.set_current_context(self.context)
        imgui.backends.opengl3_shutdown()
        if self._has_window:
            imgui.backends.glfw_shutdown()
        imgui.destroy_context(self.context)


class Panel:
    """The imgui side panel: its sections lay out the controls and change the viewer only through `ViewerState`;
    refusals are shown beside the control that asked, other messages in the status line."""

    def __init__(self, can_browse: bool = True, settings: PanelSettings | None = None):
        """`settings`: which sections are open, kept across runs (the window's, beside its recent files);
        None: every section as it starts, for this panel only (a render's)."""
        self.can_browse = can_browse   # headless renders have no desktop to open a dialog on
        self.settings = settings if settings is not None else PanelSettings(None)
        self.expr_text = ""
        self._file_dialog = None       # a pending portable_file_dialogs.open_file
        self._save_dialog = None       # a pending portable_file_dialogs.save_file
        self._save_full_resolution = False  # the pending save is a big volume's full-resolution export
        self.box = None                # the expanded panel's (x, y, width, height), imgui units
        self.iso_slider_box = None     # the iso slider's ((left, top), (right, bottom)), imgui units
        self.histogram_box = None      # the value histogram's ((left, top), (right, bottom)), likewise
        self.status_box = None         # the status line's (x, y, width, height) while it shows, likewise
        self.refusal_box = None        # a refusal's note beside the panel, likewise
        self.section_boxes: dict[str, tuple] = {}   # each of this panel's section headers, likewise
        self._go_home = False
        self.slices = SlicePanel()     # the Slices section (slice_panel.py)
        self.levels_section = LevelsSection()
        self.mesh_section = MeshSection()
        self.labels_section = LabelsSection()
        self.time_section = TimeSection()
        self.view_section = ViewSection()
        self.measure_section = MeasureSection()

    def keys(self, camera) -> dict:
        """The sections' keys, for the window's character table."""
        keys = {}
        for part in (self.time_section, self.view_section, self.measure_section):
            keys.update(part.keys(camera))
        return keys

    def draw(self, state: ViewerState, scene, camera=None) -> None:
        """Lay the panel out for `state`; `scene` (gfx/scene.py) for its stats; `camera` (model/camera.py)
        for the sections that move it or pick through it."""
        remember_sections(self.settings)
        self._collect_file_dialog(state)
        top = self._place()
        # As tall as its content, at most the window less the status line; as wide as PANEL_WIDTH.
        display = imgui.get_io().display_size
        width = px(PANEL_WIDTH)
        tallest = max(display.y - top - self.status_height() - 2 * px(MARGIN), px(PANEL_MIN_HEIGHT))
        imgui.set_next_window_size_constraints(imgui.ImVec2(width, 0.0), imgui.ImVec2(width, tallest))
        expanded, _ = imgui.begin(PANEL_TITLE, None, imgui.WindowFlags_.always_auto_resize)
        pos, size = imgui.get_window_pos(), imgui.get_window_size()
        self.box = (pos.x, pos.y, size.x, size.y) if expanded else None
        if expanded:
            self._volume_section(state)
            self.time_section.draw(state, camera)
            if state.labels:   # a label map on show: its labels stand in for the iso value and the levels
                self.iso_slider_box = self.histogram_box = None
                self.labels_section.draw(state, scene)
            else:
                self._iso_section(state)
                self.levels_section.draw(state, scene)
                self.mesh_section.draw(state)
            self._display_section(state)
            self.view_section.draw(state, camera)
            self.slices.draw(state)
            self._stats_section(state, scene)
            self.measure_section.draw(state, camera)
        panel = imgui.internal.get_current_window_read()
        self.section_boxes = dict(gui.headers)
        imgui.end()
        self._refusal_note(state, panel if expanded else None)
        self._status_line(state, scene)

    def draw_view_labels(self, state: ViewerState, camera) -> None:
        """The anatomical letters (R/L, A/P, S/I) around the part of the window the panel leaves
        to the scene, for a volume whose file defines its orientation."""
        display = imgui.get_io().display_size
        left = self.covered_width
        draw_orientation(state.volume, camera, (left, 0.0, display.x - left, display.y), state.slices)

    @property
    def covered_width(self) -> float:
        """How much of the window's left the panel hides (imgui units), so the scene centres in
        the rest: its right edge while it sits at the left edge, else 0 (dragged away or collapsed)."""
        if self.box is None or self.box[0] > PANEL_HOME[0] + PANEL_LEFT_SLACK:
            return 0.0
        return self.box[0] + self.box[2]

    def go_home(self) -> None:
        """Back to the top-left corner, expanded, on the next frame (key r)."""
        self._go_home = True

    def _place(self) -> float:
        """Home on first use and after go_home(); otherwise however the panel was dragged and the
        window resized, its title bar stays inside the window, where it can be dragged back.  Its top."""
        panel = imgui.internal.find_window_by_name(PANEL_TITLE)
        if panel is None or self._go_home:
            imgui.set_next_window_pos(imgui.ImVec2(*PANEL_HOME))
            imgui.set_next_window_collapsed(False)
            self._go_home = False
            return PANEL_HOME[1]
        display = imgui.get_io().display_size
        keep = min(PANEL_KEEP_VISIBLE, panel.size.x)
        x = max(min(panel.pos.x, display.x - keep), keep - panel.size.x)
        y = max(min(panel.pos.y, display.y - imgui.get_frame_height()), 0.0)
        if (x, y) != (panel.pos.x, panel.pos.y):
            imgui.set_next_window_pos(imgui.ImVec2(x, y))
        return y

    # --- sections ----------------------------------------------------------
    def _volume_section(self, state: ViewerState) -> None:
        if not section("Volume"):
            return
        if state.opening.loading is not None:
            imgui.progress_bar(state.opening.loading.fraction, imgui.ImVec2(-1, 0), state.opening.loading.message)
        if state.volume is not None:
            volume = state.volume
            shape = "x".join(str(n) for n in volume.data.shape)
            imgui.text_wrapped(f"{volume.name}  {shape} {volume.data.dtype}")
            for note in shown_notes(state):
                imgui.text_wrapped(note)
            LabelsSection.offer(state)
            # The checkbox's words for the package's gradient direction: "ascent" is inside below.
            toggled, below = imgui.checkbox("object below the level", state.gradient_direction == "ascent")
            tooltip("on for signed distances (negative inside), off for densities such as CT;\n"
                    "normals point out of the object and ties count as inside (--inside)")
            if toggled:
                act(state, state.set_gradient_direction, "ascent" if below else "descent")
        current = state.volume.name if state.volume is not None else ""
        choose(state, "built-in", current if current in builtin_names() else "", builtin_names(), state.opening.open)
        if state.recent.paths and imgui.begin_combo("recent", ""):
            for path in state.recent.paths:
                if imgui.selectable(Path(path).name + "##" + path, False)[0]:
                    act(state, state.opening.open, path)
                tooltip(path)
            imgui.end_combo()
        if self.can_browse and imgui.button("Open file...") and self._file_dialog is None:
            self._open_file_dialog(state)
        if self.can_browse and state.volume is not None:
            imgui.same_line()
            if imgui.button("Save mesh...") and self._save_dialog is None:
                self._open_save_dialog(state)
        if state.saving.exporting is not None:
            imgui.progress_bar(state.saving.exporting.fraction, imgui.ImVec2(-1, 0), state.saving.exporting.message)
        elif self.can_browse and state.full_volume is not None:
            if imgui.button("Export full resolution...") and self._save_dialog is None:
                self._open_save_dialog(state, full_resolution=True)
            tooltip("the whole volume's mesh at this level, a chunk at a time in the background")
        entered, self.expr_text = imgui.input_text_with_hint(
            "expr", EXPR_HINT, self.expr_text, imgui.InputTextFlags_.enter_returns_true)
        if (entered or imgui.button("Show expr")) and self.expr_text.strip():
            act(state, state.opening.open, "expr:" + self.expr_text.strip())

    def _iso_section(self, state: ViewerState) -> None:
        self.iso_slider_box = self.histogram_box = None
        if not section("Iso value") or state.volume is None:
            return
        low, high = state.value_range   # the volume's
        # The slider writes no value under its grab: the level stands beside it, where it can be typed
        # (applied on Enter, so half-typed numbers do not extract), as the Surfaces list writes it.
        exact_width = px(EXACT_WIDTH)
        imgui.set_next_item_width(-exact_width - imgui.get_style().item_spacing.x)
        changed, value = imgui.slider_float("##iso", state.iso, low, high, "")
        self.iso_slider_box = (tuple(imgui.get_item_rect_min()), tuple(imgui.get_item_rect_max()))
        if changed:   # through `act`, as every control: a refusal is its one line beside the slider
            act(state, state.levels.set_value, value)
        imgui.same_line()
        imgui.set_next_item_width(exact_width)
        typed, value = imgui.input_double("##exact", state.iso, 0.0, 0.0, level_format((low, high)),
                                          imgui.InputTextFlags_.enter_returns_true)
        if typed:
            act(state, state.levels.set_value, value)
        tooltip("the level: type a value and press Enter")
        if state.histogram is not None:
            self._histogram(state, (low, high))
        imgui.text(f"range {level_text(low, (low, high))} .. {level_text(high, (low, high))}")
        imgui.same_line()
        running = state.levels.animation.running
        toggled, animate = imgui.checkbox("animate (space)", running)
        if toggled and animate != running:
            act(state, state.levels.toggle_animation)

    def _histogram(self, state: ViewerState, value_range: tuple[float, float]) -> None:
        """The values' histogram (log counts) with the level marked; a click or drag on it sets the level."""
        top_left = imgui.get_cursor_screen_pos()
        size = imgui.ImVec2(imgui.get_content_region_avail().x, px(HISTOGRAM_HEIGHT))
        self.histogram_box = ((top_left.x, top_left.y), (top_left.x + size.x, top_left.y + size.y))
        # The button first: of overlapping items, the first submitted takes the mouse.
        imgui.invisible_button("##histogram_pick", size)
        if imgui.is_item_active():
            act(state, state.levels.set_value,
                level_at((imgui.get_io().mouse_pos.x - top_left.x) / size.x, value_range))
        else:
            tooltip("values in the volume (log counts): click or drag to set the level")
        imgui.set_cursor_screen_pos(top_left)
        imgui.plot_histogram("##histogram", state.histogram, graph_size=size)
        levels = state.levels
        for i, level in enumerate(levels.values()):   # every level, the selected one thicker
            x = top_left.x + fraction_of(level, value_range) * size.x
            colour = imgui.get_color_u32(imgui.ImVec4(*levels.color(i, state.style.front_color), 1.0))
            imgui.get_window_draw_list().add_line(imgui.ImVec2(x, top_left.y), imgui.ImVec2(x, top_left.y + size.y),
                                                  colour, 3.0 if i == levels.selected else 2.0)

    def _display_section(self, state: ViewerState) -> None:
        if not section("Display"):
            return
        style = state.style
        style.lighting = imgui.checkbox("lighting (l)", style.lighting)[1]
        imgui.same_line()
        style.wireframe = imgui.checkbox("wireframe (w)", style.wireframe)[1]
        imgui.same_line()
        style.show_box = imgui.checkbox("box", style.show_box)[1]
        tooltip("the volume's bounding box")
        # Swatches (a click opens the picker): two rows less than RGB fields.
        swatch = imgui.ColorEditFlags_.no_inputs
        style.front_color = tuple(imgui.color_edit3("front", list(style.front_color), swatch)[1])
        tooltip("the surfaces' outside (the first level's colour)")
        imgui.same_line()
        style.back_color = tuple(imgui.color_edit3("back", list(style.back_color), swatch)[1])
        tooltip("the surfaces' inside, where a hole or an open edge shows it")

    def _stats_section(self, state: ViewerState, scene) -> None:
        if not section("Stats"):
            return
        if state.labels:   # what is drawn: the visible labels, not the (hidden) level's mesh
            shown, vertices, triangles = scene.stats.label_counts()
            imgui.text(f"labels     {shown} of {len(state.labels.layers)} shown")
            imgui.text(f"vertices   {vertices:,}")
            imgui.text(f"triangles  {triangles:,}")
        else:
            self._level_stats(state, scene)
        imgui.text(f"frame      {state.frame_ms:.1f} ms" if state.frame_ms else "frame      -")
        imgui.text_wrapped(f"GL: {state.gl_renderer}")

    @staticmethod
    def _level_stats(state: ViewerState, scene) -> None:
        imgui.text(f"vertices   {scene.stats.n_vertices:,}")
        imgui.text(f"triangles  {scene.stats.n_triangles:,}")
        if scene.stats.shown_shape is not None:
            full = state.full_volume.data.shape if state.full_volume is not None else state.volume.data.shape
            shown = "x".join(map(str, scene.stats.shown_shape))
            if tuple(scene.stats.shown_shape) == tuple(full):
                imgui.text(f"shown      {shown}, full resolution")
            else:
                imgui.text_colored(NOTE_COLOR, f"shown      {shown} of {'x'.join(map(str, full))}")
                tooltip(f"memory budget {state.budget.text}" if state.step > 1 else "a preview while the level moves")
        if state.bricks is not None:
            imgui.text_colored(NOTE_COLOR, f"bricks     {state.bricks.text}")
        note = rays_note(state)
        if note is not None:
            imgui.text_colored(NOTE_COLOR, f"rays       {rays_line(state)}")
            tooltip(note)
        if scene.stats.preview_step > 1:
            imgui.text_colored(NOTE_COLOR, f"preview at 1/{scene.stats.preview_step} resolution")
            tooltip(pace_text(scene.pacing.pace))
        imgui.text(f"extraction {scene.stats.extract_ms:.1f} ms")
        if len(state.levels) > 1:
            for i in range(len(state.levels)):
                triangles, ms = scene.stats.level_stats(i)
                imgui.text(f"surface {i + 1}  {triangles:,} triangles, {ms:.1f} ms")

    # --- beside the panel: messages and refusals, moving no control -------------------
    @staticmethod
    def status_height() -> float:
        """The status line's height: kept free under the panel whether or not it shows."""
        return imgui.get_frame_height() + 2 * imgui.get_style().window_padding.y

    def status(self, state: ViewerState, scene) -> tuple[str, imgui.ImVec4] | None:
        """The status line's text and colour: an error (not a refusal, shown at its control, unless the
        panel is folded away), else the selected level's empty-surface hint or its hidden-surface one,
        else the last message; None for none."""
        if state.error and (refusal(state, PANEL_TITLE) is None or self.box is None):
            return state.error, ERROR_COLOR
        if state.volume is not None and not state.labels and scene is not None and scene.surface is not None \
                and scene.stats.preview_step == 1 and scene.stats.n_triangles == 0 and surfaces_drawn(state):
            return empty_level_hint(state.iso, state.value_range, state.histogram), HINT_COLOR
        hidden = self.levels_section.hidden_in if not state.labels else {}
        if state.levels.selected in hidden:
            return self.levels_section.flag_text(state, state.levels.selected), HINT_COLOR
        if state.message:
            return state.message, NOTE_COLOR
        return None

    def _status_line(self, state: ViewerState, scene) -> None:
        """One line at the window's bottom-left, over the scene; the whole text in a tooltip when cut."""
        shown = self.status(state, scene)
        self.status_box = None
        if shown is None:
            return
        text, colour = " ".join(shown[0].split()), shown[1]   # one line, whatever it was given
        display = imgui.get_io().display_size
        height = self.status_height()
        padding = imgui.get_style().window_padding.x
        width = min(imgui.calc_text_size(text).x + 2 * padding, display.x - 2 * px(MARGIN))
        imgui.set_next_window_pos(imgui.ImVec2(px(MARGIN), display.y - px(MARGIN) - height))
        imgui.set_next_window_size(imgui.ImVec2(width, height))
        imgui.set_next_window_bg_alpha(0.85)
        imgui.begin(STATUS_TITLE, None, FLOATING | imgui.WindowFlags_.no_bring_to_front_on_focus)
        imgui.align_text_to_frame_padding()
        imgui.text_colored(colour, text)
        if imgui.calc_text_size(text).x > width - 2 * padding:
            tooltip(text)
        pos, size = imgui.get_window_pos(), imgui.get_window_size()
        self.status_box = (pos.x, pos.y, size.x, size.y)
        imgui.end()

    def _refusal_note(self, state: ViewerState, panel) -> None:
        """A refused change's one line, beside the panel at its control's row (inside the panel's view)."""
        note = refusal(state, PANEL_TITLE)
        self.refusal_box = None
        if note is None or panel is None:
            return
        top = panel.pos.y + note.y - panel.scroll.y
        top = min(max(top, panel.pos.y), panel.pos.y + panel.size.y - note.height)
        imgui.set_next_window_pos(imgui.ImVec2(panel.pos.x + panel.size.x + px(gui.TOOLTIP_GAP), top))
        imgui.begin(REFUSAL_TITLE, None, FLOATING | imgui.WindowFlags_.always_auto_resize
                    | imgui.WindowFlags_.no_inputs)
        imgui.push_text_wrap_pos(px(REFUSAL_WIDTH))
        imgui.text_colored(ERROR_COLOR, note.text)
        imgui.pop_text_wrap_pos()
        pos, size = imgui.get_window_pos(), imgui.get_window_size()
        self.refusal_box = (pos.x, pos.y, size.x, size.y)
        imgui.end()

    @staticmethod
    def _dialogs(state: ViewerState, instead: str):
        """portable_file_dialogs where the desktop has a native dialog (zenity, kdialog on Linux), else None:
        the browser inside the window (file_browser.py) stands in."""
        if not has_dialog_tool():
            return None
        import imgui_bundle.portable_file_dialogs as pfd  # only on demand: it spawns a process
        return pfd

    def _browser(self, state: ViewerState) -> FileBrowser:
        if getattr(self, "browser", None) is None:
            self.browser = FileBrowser(default_recent_folders() if self.can_browse else None)
        return self.browser

    def _open_file_dialog(self, state: ViewerState) -> None:
        pfd = self._dialogs(state, "drop the file on the window or pass it on the command line")
        folders = [str(Path(path).parent) for path in state.recent.paths]
        if pfd is None:
            self._browser(state).open_file("Open volume", folders[0] if folders else Path.cwd(),
                                           patterns_of(VOLUME_FILE_FILTERS), "open", folders)
        else:
            self._file_dialog = pfd.open_file("Open volume", str(Path.cwd()), VOLUME_FILE_FILTERS)

    def _open_save_dialog(self, state: ViewerState, full_resolution: bool = False) -> None:
        pfd = self._dialogs(state, "use `isoscope export` on the command line")
        title = "Export full resolution" if full_resolution else "Save mesh"
        if pfd is None:
            self._browser(state).save_file(title, Path.cwd() / "isoscope-mesh.stl", patterns_of(MESH_FILE_FILTERS),
                                           "full resolution" if full_resolution else "save mesh")
        else:
            self._save_full_resolution = full_resolution
            self._save_dialog = pfd.save_file(title, str(Path.cwd() / "isoscope-mesh.stl"), MESH_FILE_FILTERS)

    def _collect_file_dialog(self, state: ViewerState) -> None:
        # The dialogs run in other processes; poll them so the UI keeps drawing meanwhile.
        if self._file_dialog is not None and self._file_dialog.ready(0):
            paths = self._file_dialog.result()
            self._file_dialog = None
            if paths:
                act(state, state.opening.open, paths[0])
        if self._save_dialog is not None and self._save_dialog.ready(0):
            path = self._save_dialog.result()
            self._save_dialog = None
            if path:
                saving = state.saving
                act(state, saving.export_full_resolution if self._save_full_resolution else saving.request_save, path)
        browser = self._browser(state)
        chosen = browser.draw()   # the browser inside the window, where there is no native dialog
        if chosen and browser.purpose == "open":
            act(state, state.opening.open, chosen)
        elif chosen:
            saving = state.saving
            act(state, saving.export_full_resolution if browser.purpose == "full resolution" else saving.request_save,
                chosen)

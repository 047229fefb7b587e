"""The desktop window: GLFW + an OpenGL 4.3 core context (else 4.1, as on macOS), the frame loop, mouse
and keys.

Each frame: poll input -> lay out the panel (which changes the state, `ViewerState`,
and extracts nothing) -> `scene.update()` brings the GPU in line with the state and
re-extracts if the value moved -> draw the mesh straight from the extractor's
buffers -> draw imgui on top -> swap.
"""
from __future__ import annotations

import ctypes
import time
from dataclasses import dataclass
from functools import partial
from pathlib import Path

import glfw
import moderngl

from ...errors import IsoscopeError
from ...gpu.context import DRAWING_GL, is_software_renderer
from ...volumes import Volume, open_volume
from ..gfx.renderer import read_rgb
from ..gfx.scene import USER_ERRORS
from ..gfx.screenshot import next_screenshot_path, save_png
from ..model.errors import one_line
from ..model.recent import RecentFiles
from ..model.settings import PanelSettings
from ..model.state import ViewerState
from .app import ViewerApp
from .panel import ImguiLayer, Panel

# GLFW errors reach the user through WindowUnavailable's one line, not as Python warnings.
glfw.ERROR_REPORTING = "ignore"

FRAME_MS_SMOOTHING = 0.1   # exponential moving average: a readable number, not a flicker
MINIMISED_WAIT_S = 0.1
WHEEL = -1                 # MouseEvent.action of a wheel turn
ROUTE_WAIT_FRAMES = 4      # imgui handles a mouse event within a frame or two of its arrival
ORBIT_PIXELS_PER_SIDE = 450.0
"""A drag across the window's shorter side orbits as far as this many pixels at the camera's rate (0.4
degrees a pixel: 180 degrees), whatever the window's size: 100 px up an 800 px window turns 22.5 degrees."""


@dataclass
class MouseEvent:
    """A press, release or wheel turn, kept until imgui has handled it (see _route_mouse_events)."""
    button: int | None          # None: the wheel
    action: int                 # glfw.PRESS, glfw.RELEASE, or WHEEL
    mods: int
    cursor: tuple[float, float]
    wheel: float = 0.0          # notches, positive away from the user
    frames_waited: int = 0


class WindowUnavailable(IsoscopeError, RuntimeError):
    """No window could be opened (no display, no OpenGL 4.1)."""


def _glfw_error_text() -> str:
    _, description = glfw.get_error()
    return description.decode() if isinstance(description, bytes) else str(description or "")


GL_VERSIONS = ((4, 3), (4, 1))
"""Asked for in turn: 4.3 (the GPU extractor's compute shaders), else 4.1 core forward-compatible (macOS;
meshes then come from the CPU, gfx/cpu_surface.py)."""


def _open_gl_window(size, title: str, samples: int):
    glfw.window_hint(glfw.OPENGL_PROFILE, glfw.OPENGL_CORE_PROFILE)
    glfw.window_hint(glfw.OPENGL_FORWARD_COMPAT, True)
    glfw.window_hint(glfw.SAMPLES, samples)       # GLFW falls back to no MSAA where there is none
    glfw.window_hint(glfw.SCALE_TO_MONITOR, True)  # HiDPI: a window the same physical size
    window, messages = None, []
    for major, minor in GL_VERSIONS:
        glfw.window_hint(glfw.CONTEXT_VERSION_MAJOR, major)
        glfw.window_hint(glfw.CONTEXT_VERSION_MINOR, minor)
        window = glfw.create_window(size[0], size[1], title, None, None)
        if window:
            break
        messages.append(f"{major}.{minor}: {_glfw_error_text()}")
    if not window:
        glfw.terminate()
        raise WindowUnavailable(f"cannot create an OpenGL 4.1 (or 4.3) core window ({'; '.join(messages)}); "
                                f"update the graphics driver, or {_without_a_window()}")
    glfw.make_context_current(window)
    glfw.swap_interval(1)
    return window, moderngl.create_context(require=DRAWING_GL)


def _without_a_window() -> str:
    """What works here without a window: `isoscope render` where a headless OpenGL 4.1 context can be had
    (it draws with one), else only `isoscope export` and `measure`, which need no OpenGL at all."""
    from ...gpu.context import DRAWING_GL, GLUnavailable, standalone
    try:
        standalone(DRAWING_GL).release()
    except GLUnavailable:
        return "use `isoscope export` for a mesh file or `isoscope measure` (no OpenGL needed: there is none here)"
    return "use `isoscope render` for a PNG"


class ViewerWindow:
    """The desktop window: a GLFW window with its GL context, the viewer's app drawn in it, mouse and key input,
    screenshots and the frame loop."""

    def __init__(self, volume: Volume | None = None, iso: float | None = None, size=(1280, 800),
                 screenshot_dir=".", recent: RecentFiles | None = None, title="isoscope",
                 msaa: int | None = None, screenshot_scale: int = 1):
        """msaa: samples per pixel; None = 4 on a GPU, 0 on a software renderer.
        screenshot_scale: key `s` saves the scene at this many times the window's pixels (no panel)."""
        if not glfw.init():
            raise WindowUnavailable(f"cannot open a window ({_glfw_error_text() or 'no display'}); "
                                    f"run it on a desktop, or under xvfb-run, or {_without_a_window()}")
        self.window, self.ctx = _open_gl_window(size, title, 4 if msaa is None else msaa)
        if msaa is None and is_software_renderer(self.ctx):
            # 4x MSAA triples llvmpipe's frame time (measured: 38 vs 13 ms idle at 1280x800):
            # a responsive slider matters more there than smooth edges.
            self.ctx.release()
            glfw.destroy_window(self.window)
            self.window, self.ctx = _open_gl_window(size, title, 0)
        self.screenshot_dir = Path(screenshot_dir)
        self.screenshot_scale = int(screenshot_scale)
        # expr: volumes typed in the panel are sampled on the GPU, in the window's context.
        self.state = ViewerState(recent if recent is not None else RecentFiles(RecentFiles.default_path()),
                                 opener=partial(open_volume, ctx=self.ctx))
        self.settings = PanelSettings.beside(self.state.recent)   # folded sections, kept with the recent files
        self.app = ViewerApp(self.ctx, self.state, Panel(can_browse=True, settings=self.settings), previews=True)
        self._install_callbacks()   # before imgui's: its GLFW backend chains to these
        self.imgui = ImguiLayer(ctypes.cast(self.window, ctypes.c_void_p).value)
        self._scale_ui_to_monitor()
        self.panel.time_section.record_dir = self.screenshot_dir   # Record's movies go beside screenshots
        self._drag_button: int | None = None
        self._mouse_events: list[MouseEvent] = []   # waiting for imgui to say whether they are its
        self._last_cursor = glfw.get_cursor_pos(self.window)
        self._screenshot_requested = False
        self._last_frame_start: float | None = None
        self.last_screenshot: Path | None = None
        if volume is not None:
            try:
                self.scene.show(volume, iso)
            except USER_ERRORS as exc:   # the window opens, with the reason in its panel
                self.state.error = one_line(exc)

    # --- loop --------------------------------------------------------------
    def run(self, max_frames: int | None = None) -> None:
        """Draw frames until the window is closed (or `max_frames` are drawn), then close it."""
        frames = 0
        try:
            while self.draw_frame() and (max_frames is None or frames < max_frames):
                frames += 1
        finally:
            self.close()

    def draw_frame(self) -> bool:
        """Process input and draw one frame; False once the window should close."""
        glfw.poll_events()
        if glfw.window_should_close(self.window):
            return False
        fb_width, fb_height = glfw.get_framebuffer_size(self.window)
        if fb_width == 0 or fb_height == 0:
            # Minimised: nothing to draw into; sleep until something happens.
            glfw.wait_events_timeout(MINIMISED_WAIT_S)
            self._last_frame_start = None
            return True
        now = time.perf_counter()
        dt = 0.0 if self._last_frame_start is None else now - self._last_frame_start
        if dt:
            self.state.frame_ms += FRAME_MS_SMOOTHING * (1000 * dt - self.state.frame_ms)
        self._last_frame_start = now

        self.imgui.new_frame()
        self._route_mouse_events()
        self.panel.draw(self.state, self.scene, self.camera)
        self.panel.measure_section.pick(self.scene, self.camera, self.panel.covered_width)   # ctrl+click: probe
        if self.app.follow(dt) and self.state.volume is not None:
            glfw.set_window_title(self.window, f"isoscope - {self.state.volume.name}")
        self.panel.draw_view_labels(self.state, self.camera)

        self.ctx.screen.use()
        pixels_per_unit = fb_width / max(glfw.get_window_size(self.window)[0], 1)  # framebuffer scale
        covered_left = int(self.panel.covered_width * pixels_per_unit)
        self.app.draw((0, 0, fb_width, fb_height), covered_left=covered_left, moving=self._moving())
        # Record: the scene, no panel.  On screen it is centred in what the panel leaves free; a movie of that
        # had an empty strip where the panel was, so a frame due is drawn again, centred, as render draws it.
        self.panel.time_section.capture(
            self.ctx.screen if not covered_left else lambda: self.app.offscreen((fb_width, fb_height)),
            (fb_width, fb_height))
        self.imgui.render()
        if self._screenshot_requested:
            self._save_screenshot((fb_width, fb_height))
        glfw.swap_buffers(self.window)
        return True

    def _moving(self) -> bool:
        """Whether the view or the level is moving this frame: a drag in the scene, the level animated or
        playing, or the selected level still a preview."""
        state = self.state
        return (self._drag_button is not None or state.levels.animation.running or state.series.playing
                or self.scene.stats.preview_step > 1)

    # The app's parts, as the window's callers and tests name them.
    scene = property(lambda self: self.app.scene)
    renderer = property(lambda self: self.app.renderer)
    camera = property(lambda self: self.app.camera)
    panel = property(lambda self: self.app.panel)

    def _save_screenshot(self, size) -> None:
        # Read the back buffer before the swap: exactly what this frame shows, panel included.
        self._screenshot_requested = False
        path = next_screenshot_path(self.screenshot_dir)
        try:
            save_png(read_rgb(self.ctx.screen, size) if self.screenshot_scale == 1 else
                     self.app.offscreen((size[0] * self.screenshot_scale, size[1] * self.screenshot_scale),
                                        alpha=self.state.style.transparent_background), path)
        except moderngl.Error as exc:
            self.state.error = (f"cannot render a {self.screenshot_scale}x screenshot ({exc}); "
                                "use a smaller --screenshot-scale")
            return
        except OSError as exc:
            self.state.error = f"cannot save the screenshot to {path}: {exc.strerror}; pick a writable --screenshot-dir"
            return
        self.last_screenshot = path
        self.state.message = f"screenshot saved: {path}"
        print(self.state.message, flush=True)

    def _scale_ui_to_monitor(self) -> None:
        """The panel's sizes and fonts at the monitor's content scale (2 on most 4K screens)."""
        self.imgui.set_scale(max(1.0, *glfw.get_window_content_scale(self.window)))

    def close(self) -> None:
        """Finish a recording under way, free the app's and imgui's objects and destroy the window; closing twice does
        nothing."""
        if self.window is None:
            return
        self.panel.time_section.recorder.stop()   # a recording under way is written whole
        self.app.release()
        self.imgui.shutdown()
        glfw.destroy_window(self.window)
        glfw.terminate()
        self.window = None

    # --- input -------------------------------------------------------------
    def _install_callbacks(self) -> None:
        glfw.set_char_callback(self.window, self._on_char)
        glfw.set_key_callback(self.window, self._on_key)
        glfw.set_mouse_button_callback(self.window, self._on_mouse_button)
        glfw.set_cursor_pos_callback(self.window, self._on_cursor)
        glfw.set_scroll_callback(self.window, self._on_scroll)
        glfw.set_drop_callback(self.window, self._on_drop)
        glfw.set_window_content_scale_callback(self.window, lambda window, x, y: self._scale_ui_to_monitor())

    def _typing_in_panel(self) -> bool:
        from .gui import imgui
        return imgui.get_io().want_text_input

    def _on_char(self, window, codepoint: int) -> None:
        if self._typing_in_panel():
            return
        character = chr(codepoint)
        state, levels = self.state, self.state.levels
        actions = {
            "=": lambda: levels.nudge(+0.01),
            "-": lambda: levels.nudge(-0.01),
            "+": lambda: levels.nudge(+0.10),
            "_": lambda: levels.nudge(-0.10),
            " ": levels.toggle_animation,
            "w": lambda: setattr(state.style, "wireframe", not state.style.wireframe),
            "l": lambda: setattr(state.style, "lighting", not state.style.lighting),
            "r": self._reset_view,
            "s": self.request_screenshot,
        }
        actions.update(self.panel.keys(self.camera))
        action = actions.get(character.lower() if character.isalpha() else character)
        if action is not None:
            action()

    def _reset_view(self) -> None:
        """Key r: the camera's home view, and the panel back in its corner."""
        self.camera.reset()
        self.panel.go_home()

    def request_screenshot(self) -> None:
        """Save a screenshot after the next frame is drawn (key `s`)."""
        self._screenshot_requested = True

    def _on_key(self, window, key, scancode, action, mods) -> None:
        if key == glfw.KEY_ESCAPE and action == glfw.PRESS and not self._typing_in_panel():
            glfw.set_window_should_close(window, True)

    def _on_mouse_button(self, window, button, action, mods) -> None:
        # Routed after imgui.new_frame(), not here: want_capture_mouse read here describes the previous
        # frame, so a press that came with the cursor's arrival over the panel went to the camera and
        # the slider both.
        if button <= glfw.MOUSE_BUTTON_MIDDLE:
            self._mouse_events.append(MouseEvent(button, action, mods, self._last_cursor))

    def _route_mouse_events(self) -> None:
        """After imgui.new_frame(): the camera gets each press and wheel turn that imgui did not take.

        imgui may hold an event over to a later frame (its input trickling: one change per button
        and frame, no move after a press or a wheel turn), so events wait, in order, for the frame
        in which imgui handled them; ROUTE_WAIT_FRAMES bounds the wait should imgui drop one."""
        from .gui import imgui
        io = imgui.get_io()
        handled = {(button, glfw.PRESS) for button in range(3) if io.mouse_clicked[button]}
        handled |= {(button, glfw.RELEASE) for button in range(3) if io.mouse_released[button]}
        if io.mouse_wheel or io.mouse_wheel_h:
            handled.add((None, WHEEL))
        waiting = []
        for event in self._mouse_events:
            key = (event.button, event.action)
            if waiting or (key not in handled and event.frames_waited < ROUTE_WAIT_FRAMES):
                event.frames_waited += 1
                waiting.append(event)
                continue
            if event.button is not None:
                handled.discard(key)   # one change per button and frame
            if event.action == glfw.RELEASE:
                self._drag_button = None
            elif io.want_capture_mouse:
                continue
            elif event.button is None:
                self.camera.zoom(event.wheel)
            elif event.button == glfw.MOUSE_BUTTON_LEFT and event.mods & glfw.MOD_CONTROL:
                continue   # the probe's click (measure_panel.py), not an orbit
            else:
                # Shift+left pans too, for one-button touchpads.
                self._drag_button = glfw.MOUSE_BUTTON_RIGHT if (
                    event.button == glfw.MOUSE_BUTTON_LEFT and event.mods & glfw.MOD_SHIFT) else event.button
                self._last_cursor = event.cursor   # the next move drags from where the press was
        self._mouse_events = waiting

    def _on_cursor(self, window, x: float, y: float) -> None:
        dx, dy = x - self._last_cursor[0], y - self._last_cursor[1]
        self._last_cursor = (x, y)
        if self._drag_button == glfw.MOUSE_BUTTON_LEFT:
            # The same turn for a drag across the window, however big the window (ORBIT_PIXELS_PER_SIDE).
            per_side = ORBIT_PIXELS_PER_SIDE / max(min(glfw.get_window_size(window)), 1)
            self.camera.orbit(dx * per_side, dy * per_side)
        elif self._drag_button in (glfw.MOUSE_BUTTON_RIGHT, glfw.MOUSE_BUTTON_MIDDLE):
            self.camera.pan(dx, dy, glfw.get_window_size(window)[1])

    def _on_scroll(self, window, x_offset: float, y_offset: float) -> None:
        self._mouse_events.append(MouseEvent(None, WHEEL, 0, self._last_cursor, y_offset))

    def _on_drop(self, window, paths) -> None:
        if paths:
            self.state.opening.open(paths[0])

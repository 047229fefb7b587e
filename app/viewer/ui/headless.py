"""The viewer's scene without a window: render into a multisampled FBO of an EGL context.

`isoscope render` and the tests use this; it draws exactly what the window
draws (same state, scene, renderer and panel), so a PNG from here shows what a
user would see.  Where the window shows a failure in its panel, the headless
viewer's `show`, `open` and `show_levels` raise it.
"""
from __future__ import annotations

from functools import partial

import numpy as np

from ...core.budget import requested_budget
from ...errors import InputError
from ...gpu.context import DRAWING_GL, current_or_standalone
from ...volumes import Volume, open_volume
from ...volumes.volume import shape_text
from ..gfx.colorbar import draw_colorbar
from ..gfx.renderer import OffscreenTarget
from ..gfx.screenshot import save_png
from ..model.errors import ViewerError
from ..model.raycast import surfaces_drawn
from ..model.state import ViewerState
from .app import ViewerApp
from .panel import ImguiLayer, Panel

MAX_RENDER_PIXELS = 4096 * 4096
"""A render's pixels at most (16.8 million: 4096x4096, 5120x3276, 3840x2160 twice over).  Its buffers
and the read-back grow with them (llvmpipe, where they are host memory, peak RSS): 3840x2160 0.5 GB
(0.9 GB with --transparent), 4096x4096 0.9 GB (1.5 GB), 7680x4320 1.6 GB (2.9 GB); 16384x16384
would take 10-20 GB, and llvmpipe's framebuffer is not complete there."""
MULTISAMPLE_BYTES = 256 << 20  # the multisampled colour + depth buffers (8 bytes a sample) at most
MAX_SAMPLES = 4
GL_SIZE_LIMITS = ("GL_MAX_RENDERBUFFER_SIZE", "GL_MAX_TEXTURE_SIZE", "GL_MAX_FRAMEBUFFER_WIDTH",
                  "GL_MAX_FRAMEBUFFER_HEIGHT", "GL_MAX_VIEWPORT_DIMS")


def max_render_size(ctx) -> tuple[int, int]:
    """The widest and tallest framebuffer the GL driver of `ctx` can make: the least of its renderbuffer,
    texture, framebuffer and viewport limits (a limit it does not report is not one)."""
    width = height = 1 << 30
    for name in GL_SIZE_LIMITS:
        value = ctx.info.get(name)
        if value is None:
            continue
        if isinstance(value, (tuple, list)):
            width, height = min(width, int(value[0])), min(height, int(value[1]))
        elif name.endswith("_WIDTH"):
            width = min(width, int(value))
        elif name.endswith("_HEIGHT"):
            height = min(height, int(value))
        else:
            width, height = min(width, int(value)), min(height, int(value))
    return width, height


def check_render_size(size, ctx=None) -> None:
    """A one-line ValueError, before anything is allocated, for an image no render can make: more than
    MAX_RENDER_PIXELS, or (with `ctx`) wider or taller than the GL driver allows."""
    width, height = int(size[0]), int(size[1])
    if width * height > MAX_RENDER_PIXELS:
        raise InputError(f"--size {width}x{height} is {width * height / 1e6:.0f} million pixels, more than a "
                         f"render makes ({MAX_RENDER_PIXELS / 1e6:.1f} million, e.g. 4096x4096 or 5120x3276: "
                         "its buffers would take gigabytes); choose a smaller --size")
    if ctx is not None:
        max_width, max_height = max_render_size(ctx)
        if width > max_width or height > max_height:
            renderer = ctx.info.get("GL_RENDERER", "this OpenGL driver")
            raise InputError(f"--size {width}x{height} is beyond the largest image {renderer} can render, "
                             f"{max_width}x{max_height} (its GL_MAX_RENDERBUFFER_SIZE, GL_MAX_VIEWPORT_DIMS, "
                             "GL_MAX_TEXTURE_SIZE); choose a smaller --size")


def render_samples(size) -> int:
    """Multisamples for a render of `size`: 4, fewer where 4 would pass MULTISAMPLE_BYTES (a 4096x4096
    render gets 2; past the pixels' resolution a sample more matters less than a gigabyte less)."""
    per_sample = 8 * int(size[0]) * int(size[1])
    return max(1, min(MAX_SAMPLES, MULTISAMPLE_BYTES // per_sample))


class HeadlessViewer:
    """The viewer without a window: the window's state, scene, renderer and panel drawn into an offscreen target of an
    EGL context, for `isoscope render`, the Python calls and the tests; failures are raised, not shown."""

    def __init__(self, size=(800, 600), ctx=None, memory_budget=None, previews: bool = False):
        """`memory_budget`: what a volume on show may take (a size such as "2G", or bytes; core/budget.py);
        None: the enclosing using_budget block's, else this GL's default (the GPU's memory, or half the RAM
        on a software renderer).  `previews`: a level moved by `app.follow(dt)` frame after frame gets the
        window's coarse previews (a render, `follow(0, wait=True)`, draws what is on show)."""
        budget = requested_budget(memory_budget)   # refused in one line before a context is made
        self.size = (int(size[0]), int(size[1]))
        # The process's one headless context (the API's too): a second standalone context would
        # become current and leave the first one's compiled programs running in the wrong context.
        # 4.3 where the driver has it, else 4.1 core: meshes then come from the CPU (gfx/cpu_surface.py).
        self.ctx = ctx if ctx is not None else current_or_standalone(DRAWING_GL)
        check_render_size(self.size, self.ctx)  # "the framebuffer is not complete" is no message
        self.state = ViewerState(opener=partial(open_volume, ctx=self.ctx), memory_budget=budget)
        self.app = ViewerApp(self.ctx, self.state, Panel(can_browse=False), previews=previews)
        self.target = OffscreenTarget(self.ctx, self.size, samples=render_samples(self.size))
        self._imgui: ImguiLayer | None = None   # made on the first render with the panel

    # The app's parts, as callers and tests name them.
    scene = property(lambda self: self.app.scene)
    renderer = property(lambda self: self.app.renderer)
    camera = property(lambda self: self.app.camera)
    _panel = property(lambda self: self.app.panel, lambda self, panel: setattr(self.app, "panel", panel))

    def show(self, volume: Volume, iso: float | None = None, azimuth=None, elevation=None) -> None:
        """Load `volume` and frame it; what fails is raised (the old volume stays)."""
        self.app.show(volume, iso, azimuth, elevation)

    def frame(self, azimuth=None, elevation=None) -> None:
        """The camera and box fitted to the volume on show (a scan's superior up, model/camera.py)."""
        self.app.frame(azimuth, elevation)

    def open(self, spec: str, wait_s: float = 60.0, **open_options) -> None:
        """`state.opening.open`, its answer waited for and shown (as a frame of the window would); what
        fails is raised, the old volume staying on show."""
        request = self.state.opening.open(spec, **open_options)
        for response in self.state.jobs.poll(wait_s):
            if response.request_id == request:
                self.scene.show_opened(self.state.opening.opened(response))
                self.app.follow(0.0, wait=True, raise_errors=True)   # framed, and a scene put on it
                return
        raise ViewerError(f"{spec[:80]} was not read within {wait_s:g} s")

    def show_levels(self, volume: Volume, isos, opacities=(), color_by=None, colormap=None,
                    azimuth=None, elevation=None) -> None:
        """`show` with several levels (the first selected), their opacities in order, and colour by;
        a bad value raises."""
        self.show(volume, isos[0], azimuth, elevation)
        state = self.state
        for value in isos[1:]:
            state.levels.add(value)
            self.update()   # each level's mesh made (and kept) before the next moves the extractor
        for i, opacity in enumerate(opacities):
            state.levels.set_opacity(i, opacity)
        if color_by is not None or colormap is not None:
            state.set_color_by(color_by or "value", colormap)
        if len(isos) > 1:
            state.levels.select(0)
        self.update()

    def update(self) -> None:
        """A frame's GPU work, finished (sharp features too); what fails is raised."""
        self.state.error = None
        self.scene.update(0.0, wait=True)
        if self.state.error is not None:
            raise ViewerError(self.state.error)

    def render(self, panel: bool = False, letters: bool = False) -> np.ndarray:
        """Re-extract if the iso value changed, draw, and return (height, width, 3) uint8 pixels
        (4, straight alpha, when the style's background is transparent).  `letters`: a scan's orientation
        letters without the panel (the panel draws them anyway)."""
        if panel:
            self._layout_panel()   # the panel may change the state, as in the window
        elif letters:
            self._imgui = self._imgui or ImguiLayer()
            self._imgui.new_frame(self.size)
        if panel or letters:
            self._panel.draw_view_labels(self.state, self.camera)
        self.app.aim(self.target.viewport)   # the bricks are planned for this picture's shape
        self.app.follow(0.0, wait=True)  # a render shows the finished scene
        self.target.use()
        self.app.draw(self.target.viewport, covered_left=int(self._panel.covered_width) if panel else 0)
        if panel or letters:
            self._imgui.render()
        return self.target.read_rgba() if self.state.style.transparent_background else self.target.read_rgb()

    def picture(self, panel: bool = False, letters: bool = False) -> np.ndarray:
        """`render` as `isoscope render` shows it: with colour by and no panel, its colour bar at the right
        (the panel shows its own)."""
        pixels = self.render(panel=panel, letters=letters)
        if self.state.color_by is not None and not panel:
            pixels = draw_colorbar(pixels, self.state.color_by)
        return pixels

    def _layout_panel(self) -> None:
        if self._imgui is None:
            self._imgui = ImguiLayer()
            # imgui hides a new auto-sized window for its first frame while it measures it.
            self._imgui.new_frame(self.size)
            self._panel.draw(self.state, self.scene, self.camera)
            self._imgui.render()
        self._imgui.new_frame(self.size)
        self._panel.draw(self.state, self.scene, self.camera)

    def release(self) -> None:
        """Free imgui's objects, the app's GL objects and the offscreen target."""
        if self._imgui is not None:
            self._imgui.shutdown()
        self.app.release()
        self.target.release()


def prepared_viewer(volume: Volume, iso=None, size=(800, 600), azimuth=None, elevation=None,
                    transparent: bool = False, opacities=(), color_by=None, colormap=None, prepare=None,
                    tetrahedra: bool = False, smooth: int = 0, wireframe: bool = False,
                    raycast: str | None = None, transfer=None, with_surfaces: bool = False,
                    topology: str = "montani", sharp: float | None = None) -> HeadlessViewer:
    """A HeadlessViewer showing `volume` as render_png draws it (its arguments; `raycast`: a ray-casting
    mode, `transfer` its opacity over the values, model/raycast.py; `with_surfaces`: the surfaces drawn
    with it, gfx/renderer.py; `sharp`: Extended Marching Cubes' feature angle, the scene's sharp mesh with
    crisp normals), ready to render (again, after moving
    its camera or level: `isoscope movie`); its caller releases it.  What fails is raised."""
    viewer = HeadlessViewer(size)
    try:
        viewer.state.set_raycast(raycast)
        viewer.state.set_with_surfaces(with_surfaces)
        viewer.state.style.transparent_background = transparent
        # Set before the levels are shown, so their first meshes are made with them.
        viewer.state.set_cells("tetrahedra" if tetrahedra else "cubes")
        viewer.state.set_topology(topology)
        viewer.state.set_smooth(smooth)
        viewer.state.set_sharp(sharp)
        viewer.state.style.wireframe = wireframe
        isos = list(iso) if isinstance(iso, (list, tuple)) else [iso]
        viewer.show_levels(volume, isos, opacities, color_by, colormap, azimuth, elevation)
        viewer.state.set_transfer(transfer)
        if prepare is not None:
            prepare(viewer.state)
    except BaseException:
        viewer.release()
        raise
    return viewer


def render_png(volume: Volume, out, iso=None, size=(800, 600), azimuth=None, elevation=None,
               panel: bool = False, transparent: bool = False, opacities=(), color_by=None, colormap=None,
               prepare=None, tetrahedra: bool = False, smooth: int = 0, wireframe: bool = False, then=None,
               letters: bool = False, topology: str = "montani", sharp: float | None = None):
    """Render one view of `volume` to the PNG file `out` (RGBA with `transparent`); returns its path.
    `then(viewer)`, if given, is called once the picture is written (render --save-scene).

    `iso`: a level, or a list of up to 4 (several surfaces, `opacities` in the same order);
    `color_by`: "value", "gradient" or a volume spec of the same shape, through `colormap`, with a
    colour bar at the right (in the panel with `panel`); `prepare(state)`, if given, sets up the
    ViewerState once the volume is shown (slices, clip); `tetrahedra`: marching tetrahedra's
    surfaces instead of marching cubes'; `topology`: how cubes' ambiguous cells are decided; `sharp`: the
    feature angle of Extended Marching Cubes (edges and corners kept, drawn with crisp normals); `smooth`:
    iterations of smoothing projected onto the level set; `wireframe`: the triangles' edges drawn over;
    `letters`: a scan's orientation letters (R/L, A/P, S/I) at the picture's edges and its 2-D view's."""
    viewer = prepared_viewer(volume, iso, size, azimuth, elevation, transparent, opacities, color_by, colormap,
                             prepare, tetrahedra, smooth, wireframe, topology=topology, sharp=sharp)
    try:
        path = save_png(viewer.picture(panel=panel, letters=letters), out)
        if then is not None:
            then(viewer)
        return path
    finally:
        viewer.release()


def shown_note(viewer) -> str | None:
    """What a picture of a volume over the memory budget shows, e.g. "the surface is drawn from 256x256x200 of
    512x512x400 samples to fit the memory budget of 32.0 MiB (--memory-budget); 20 of 64 bricks at full
    resolution (20 of 64 in view)"; None where it shows every sample."""
    state, scene = viewer.state, viewer.scene
    if state.volume is None or state.full_volume is None or scene is None or not surfaces_drawn(state):
        return None
    shown, full = scene.stats.shown_shape, tuple(state.full_volume.data.shape)
    if shown is None or tuple(shown) == full:
        return None
    limits = state.refusal(full) if state.refusal is not None else None   # as big_volume.downsampled decided
    why = f"this GPU's limits ({limits})" if limits else f"the memory budget of {state.budget.text}"
    text = f"the surface is drawn from {shape_text(shown)} of {shape_text(full)} samples to fit {why}"
    return text + (f"; {state.bricks.text}" if state.bricks is not None and state.bricks.meshes else "")


def empty_level_hints(viewer) -> list[str]:
    """The panel's line for each visible level whose surface drew nothing (model/hints.py), e.g. "no surface
    at 254.0: the values lie in 0.0..254.0, most between 20.0 and 140.0"."""
    from ..model.hints import empty_level_hint
    state, scene = viewer.state, viewer.scene
    if state.volume is None or state.labels or scene is None or scene.surface is None or not surfaces_drawn(state):
        return []
    return [empty_level_hint(level.value, state.value_range, state.histogram)
            for i, level in enumerate(state.levels.items) if level.visible and scene.stats.level_stats(i)[0] == 0]


def scene_pixels(scene: dict, size=None, panel: bool = False, letters: bool = False) -> np.ndarray:
    """The picture of a saved scene (model/scene_file.py) at its own size, or `size`; `letters`: a scan's
    orientation letters."""
    from ..model.scene_file import apply_scene, scene_size, volume_spec
    spec, options = volume_spec(scene)
    viewer = HeadlessViewer(size or scene_size(scene))
    try:
        viewer.show(open_volume(spec, ctx=viewer.ctx, **options))
        apply_scene(scene, viewer.state, viewer.camera)
        return viewer.picture(panel=panel, letters=letters)
    finally:
        viewer.release()


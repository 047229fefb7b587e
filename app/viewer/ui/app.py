"""The viewer's one app: what the window, the headless viewer (and through them `isoscope.view`, `render`,
`movie` and the notebook widget) share: the state, the GPU scene that follows it, the camera, the
renderer and the panel, and the order a frame runs in.

A frame, wherever it is drawn:
  1. the panel lays itself out and changes the state (the window; the headless viewer with `panel=True`);
  2. `follow`: the scene brings the GPU in line with the state (extractions, reads answered), a volume
     new on show is framed, a scene opened through the state is put on it;
  3. `draw`: the scene into a viewport (the window's screen, or an offscreen target).
The window adds input and the swap; the headless viewer reads the pixels back.  Each GL object here has
this app as its one owner: `release` frees them.
"""
from __future__ import annotations

import numpy as np

from ..gfx.renderer import OffscreenTarget, SceneRenderer
from ..gfx.scene import USER_ERRORS, GpuScene
from ..model.camera import OrbitCamera, volume_frame
from ..model.errors import one_line
from ..model.raycast import RaySpacing
from ..model.scene_file import apply_opened_scene
from ..model.state import ViewerState
from .panel import Panel


class ViewerApp:
    """The state, the GPU scene that follows it, the camera, the renderer and the panel, and the frame order (`follow`,
    then `draw`) that the window and the headless viewer share."""

    def __init__(self, ctx, state: ViewerState, panel: Panel, previews: bool = False):
        """`previews`: coarse meshes while a level moves (the window; a render shows finished meshes)."""
        self.ctx, self.state, self.panel = ctx, state, panel
        self.scene = GpuScene(ctx, state, previews=previews)
        self.previews = previews
        self._drawn_transfer_edits = 0   # the state's transfer_edits when last drawn
        self.renderer = SceneRenderer(ctx)
        self.camera = OrbitCamera()
        self._framed_serial = -1
        self._aspect = 4 / 3   # of the viewport the next frame is drawn into (aim)
        self.rays = RaySpacing()   # with previews: how sparse the rays are while the view moves, as measured
        self._sparse_rays = False  # the last frame drew them so (its time is recorded by the next follow)

    def show(self, volume, iso: float | None = None, azimuth=None, elevation=None) -> None:
        """Put `volume` on show at `iso` and frame it from (azimuth, elevation); what fails is raised."""
        self.scene.show(volume, iso)
        self.frame(azimuth, elevation)

    def frame(self, azimuth=None, elevation=None) -> None:
        """The camera and the box fitted to the volume on show (a scan's superior up, model/camera.py)."""
        lower, upper = self.state.bounds()
        self.camera.fit(lower, upper, azimuth, elevation, volume_frame(self.state.volume))
        self.renderer.set_box(lower, upper)
        self._framed_serial = self.state.volume_serial

    def follow(self, dt_seconds: float, wait: bool = False, raise_errors: bool = False) -> bool:
        """Step 2 of a frame: the scene follows the state (`wait`: for the reads and meshes asked for), a
        volume new on show is framed, an opened scene is put on it.  Whether a new volume was framed."""
        if self._sparse_rays and dt_seconds > 0:
            self.rays.record(1000 * dt_seconds)
        self._sparse_rays = False
        self.scene.update(dt_seconds, wait=wait)
        self._refine(wait)
        framed = self.state.volume_serial != self._framed_serial
        if framed:
            self.frame()
        apply_opened_scene(self.state, self.camera, raise_errors=raise_errors)
        return framed

    def aim(self, viewport) -> None:
        """The viewport (x, y, width, height) the next frames are drawn into: the bricks are planned for its shape
        (a headless render says it before `follow`, the window's frames after the first as they draw)."""
        self._aspect = viewport[2] / max(viewport[3], 1)

    def _refine(self, wait: bool) -> None:
        """A big volume's bricks (model/bricks.py): planned for the camera, the nearest in view asked for (all
        of them, with `wait`), and the scene's buffers following."""
        bricks = self.state.bricks
        if bricks is not None:
            clip = (self.camera.view_matrix().astype(np.float64) @ self.camera.projection_matrix(self._aspect)).T
            eye = self.camera.eye()
            # the surfaces' bricks and the rays' each on their own: one's error does not stop the other
            self._saying_errors(bricks.look, self.state, eye, clip,
                                self.scene.bricks.coarse_of(self.scene.surface, self.state), wait=wait)
            self._saying_errors(bricks.rays.look, self.state, eye, clip, wait=wait,
                                each=lambda: self.renderer.follow_ray_bricks(bricks.rays))
        self.scene.follow_bricks()

    def _saying_errors(self, work, *args, **kwargs) -> None:
        """`work(*args, **kwargs)`; a user's error it raises goes to the status line in one line."""
        try:
            work(*args, **kwargs)
        except USER_ERRORS as exc:
            self.state.error = one_line(exc)

    def draw(self, viewport, covered_left: int = 0, moving: bool = False) -> None:
        """Step 3: the scene into `viewport` of the bound framebuffer, centred in what `covered_left` pixels
        of panel leave free; `moving` (the window's frames while the view or the level moves): a ray-cast
        volume at a ray per 2x2 pixels, the full picture once it rests.  With previews (the window) a frame
        after the transfer function's points moved is drawn so too: a drag over them stays fluid, and the
        first frame after it rests is whole; and the rays are as sparse as `rays` finds keeps such frames
        under its target (model/raycast.py RaySpacing, from the frames' measured times)."""
        self.aim(viewport)
        edited = self.state.transfer_edits != self._drawn_transfer_edits
        self._drawn_transfer_edits = self.state.transfer_edits
        coarse = moving or (self.previews and edited)
        if coarse and self.previews:
            coarse = self.rays.spacing
            self._sparse_rays = self.state.raycast is not None
        self.renderer.draw_scene(self.scene, self.camera, viewport, covered_left=covered_left, coarse=coarse)

    def offscreen(self, size, alpha: bool = False) -> np.ndarray:
        """The scene drawn into a new offscreen target of `size`, centred in the whole of it (no panel), as
        `isoscope render` draws it: (H, W, 3) uint8, or RGBA with `alpha`.  The screen is bound again after."""
        target = OffscreenTarget(self.ctx, size)
        try:
            target.use()
            self.draw(target.viewport)
            return target.read_rgba() if alpha else target.read_rgb()
        finally:
            target.release()
            self.ctx.screen.use()

    def release(self) -> None:
        """Free what the app owns: the state's workers, the panel's measure jobs, the scene and the renderer."""
        self.state.release()
        self.panel.measure_section.release()
        self.scene.release()
        self.renderer.release()

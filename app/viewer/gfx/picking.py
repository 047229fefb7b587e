"""The cursor probe: which point of the scene is under a pixel, its voxel and the volume's value there.

A pick draws the meshes on show (the same view, projection, lens shift and clip plane as the renderer)
into a depth buffer of its own, one pixel of it (a scissor), and reads that pixel's depth back; the
depth is unprojected with the camera's matrices to a world point.  The slices on show are hit by the
same ray, analytically (they are axis-aligned planes); the nearer of the two wins.  Its own buffer, not
the window's: that one is multisampled where there is MSAA, and translucent surfaces (weighted blended
OIT) write no depth, yet the user points at them too.

World here is the scene's: array index x spacing (axis 0 is x), moved by the volume's origin (a pyramid
level's coarse view: where the file puts its samples).  `Probe.world` is also given in the file's own frame
(RAS or LPS millimetres, an OME-Zarr image's scale and translation) where the file defines one, and distances
are taken there.
"""
from __future__ import annotations

from dataclasses import dataclass

import moderngl
import numpy as np

from ...core.layout import vertex_format
from ...resources import shader_source
from .slices import GL_CLIP_DISTANCE0

BACKGROUND_DEPTH = 1.0


@dataclass(frozen=True)
class Probe:
    """What lies under the cursor."""
    point: tuple[float, float, float]      # scene coordinates: index x spacing
    world: tuple[float, float, float]      # the file's frame (mm) where it has one, else `point`
    space: str                             # "RAS", "LPS", "OME-Zarr" or "index x spacing"
    voxel: tuple[int, int, int]            # the nearest sample's index
    value: float                           # the volume's value at that sample
    on: str                                # "surface" or "slice x|y|z"

    def line(self) -> str:
        """The probe in one line for the panel: what it lies on, world coordinates and their space, the voxel and its
        value."""
        x, y, z = self.world
        i, j, k = self.voxel
        return f"{self.on}: ({x:.4g}, {y:.4g}, {z:.4g}) {self.space}, voxel [{i}, {j}, {k}], value {self.value:.6g}"


def matrices(camera, viewport) -> tuple[np.ndarray, np.ndarray]:
    """(view, projection) as the renderer makes them for `viewport` = (x, y, width, height, covered_left)."""
    width, height, covered_left = viewport[2], viewport[3], viewport[4] if len(viewport) > 4 else 0
    shift_x = min(max(covered_left, 0), width // 2) / max(width, 1)
    return camera.view_matrix(), camera.projection_matrix(width / max(height, 1), shift_x)


def unproject(camera, viewport, pixel, depth: float) -> np.ndarray:
    """The scene point at framebuffer `pixel` (x right, y up, from the viewport's corner) and window-space
    `depth` (0 near .. 1 far).  pyrr's matrices are row-vector: clip = p @ view @ projection."""
    view, projection = matrices(camera, viewport)
    ndc = np.array([2.0 * (pixel[0] + 0.5) / viewport[2] - 1.0, 2.0 * (pixel[1] + 0.5) / viewport[3] - 1.0,
                    2.0 * depth - 1.0, 1.0])
    point = ndc @ np.linalg.inv(view.astype(np.float64) @ projection.astype(np.float64))
    return point[:3] / point[3]


def project(camera, viewport, point) -> tuple[float, float] | None:
    """The framebuffer pixel (x right, y up) where scene `point` is drawn, or None behind the camera."""
    view, projection = matrices(camera, viewport)
    clip = np.append(np.asarray(point, np.float64), 1.0) @ (view.astype(np.float64) @ projection.astype(np.float64))
    if clip[3] <= 0:
        return None
    ndc = clip[:2] / clip[3]
    return (ndc[0] + 1.0) / 2.0 * viewport[2] - 0.5, (ndc[1] + 1.0) / 2.0 * viewport[3] - 0.5


def ray(camera, viewport, pixel) -> tuple[np.ndarray, np.ndarray]:
    """(origin, unit direction) of the ray through `pixel`, in scene coordinates."""
    near, far = unproject(camera, viewport, pixel, 0.0), unproject(camera, viewport, pixel, 1.0)
    direction = far - near
    return near, direction / np.linalg.norm(direction)


def slice_hit(slices, spacing, shape, origin, direction) -> tuple[float, int] | None:
    """(distance along the ray, axis) of the nearest slice on show that the ray crosses inside the volume."""
    best = None
    upper = (np.asarray(shape) - 1) * np.asarray(spacing)
    for axis in range(3):
        if not slices.shown[axis] or abs(direction[axis]) < 1e-12:
            continue
        t = (slices.index[axis] * spacing[axis] - origin[axis]) / direction[axis]
        point = origin + t * direction
        inside = all(-1e-6 <= point[a] <= upper[a] + 1e-6 for a in range(3) if a != axis)
        if t > 0 and inside and (best is None or t < best[0]):
            best = (t, axis)
    return best


def probe_of(volume, point, on: str) -> Probe:
    """The probe at scene `point` of `volume` (index x spacing, moved by the volume's origin): its nearest
    sample, value and world coordinates."""
    spacing = np.asarray(volume.spacing, np.float64)
    index = (np.asarray(point, np.float64) - np.asarray(getattr(volume, "origin", (0.0, 0.0, 0.0)))) / spacing
    voxel = tuple(int(v) for v in np.clip(np.rint(index), 0, np.asarray(volume.data.shape) - 1))
    value = float(np.asarray(volume.data[voxel]))
    world, space = tuple(float(v) for v in point), "index x spacing"
    if volume.world is not None:
        matrix, space = volume.world
        world = tuple(float(v) for v in (np.asarray(matrix, np.float64) @ np.append(index, 1.0))[:3])
    return Probe(tuple(float(v) for v in point), world, space, voxel, value, on)


class Picker:
    """Reads the depth of the meshes on show under one pixel (see the module's docstring)."""

    def __init__(self, ctx: moderngl.Context):
        self.ctx = ctx
        self.program = ctx.program(vertex_shader=shader_source("mesh.vert"), fragment_shader=shader_source("flat.frag"))
        self._framebuffer: moderngl.Framebuffer | None = None
        self._size: tuple[int, int] | None = None
        self._vaos: dict = {}

    def depth(self, scene, camera, viewport, pixel) -> float:
        """Window-space depth (1: nothing) of the scene's meshes under framebuffer `pixel`; `viewport` =
        (x, y, width, height, covered_left) in framebuffer pixels, as the renderer draws it."""
        ctx = self.ctx
        width, height = int(viewport[2]), int(viewport[3])
        x, y = int(pixel[0]), int(pixel[1])
        if not (0 <= x < width and 0 <= y < height):
            return BACKGROUND_DEPTH
        self._ensure((width, height))
        view, projection = matrices(camera, viewport)
        self.program["u_view"].write(view.tobytes())
        self.program["u_projection"].write(projection.tobytes())
        slices = scene.state.slice_scene
        clip = slices.settings.clip if slices is not None else None
        self.program["u_clip_plane"].value = (clip.plane(slices.spacing, slices.origin) if clip is not None
                                              else (0.0, 0.0, 0.0, 1.0))
        previous = ctx.fbo
        self._framebuffer.use()
        ctx.viewport = (0, 0, width, height)
        ctx.scissor = (x, y, 1, 1)
        ctx.enable_only(moderngl.DEPTH_TEST)
        ctx.depth_func = "<="
        ctx.wireframe = False
        ctx.polygon_offset = (0.0, 0.0)
        self._framebuffer.clear(depth=BACKGROUND_DEPTH, viewport=(x, y, 1, 1))
        if clip is not None:
            ctx.enable_direct(GL_CLIP_DISTANCE0)
        try:
            drawn = [(mesh, look) for mesh, look in scene.drawn() if mesh.n_triangles and look.opacity > 0]
            meshes = [mesh for mesh, _ in drawn]
            for mesh, look in drawn:
                self.program["u_origin"].value = look.origin
                self._vao(mesh).render(moderngl.TRIANGLES, vertices=3 * mesh.n_triangles,
                                       first=3 * mesh.first_triangle)
            data = self._framebuffer.read(viewport=(x, y, 1, 1), attachment=-1, dtype="f4")
        finally:
            ctx.disable_direct(GL_CLIP_DISTANCE0)
            ctx.scissor = None
            _bind(previous)
        self._keep({(m.vertex_buffer, m.index_buffer) for m in meshes})
        return float(np.frombuffer(data, np.float32)[0])

    def probe(self, scene, camera, viewport, pixel) -> Probe | None:
        """What lies under framebuffer `pixel`: the nearer of the meshes' depth and the slices on show; None
        over the background (or with no volume)."""
        volume = scene.state.volume
        if volume is None:
            return None
        depth = self.depth(scene, camera, viewport, pixel)
        origin, direction = ray(camera, viewport, pixel)
        surface_t = None
        if depth < BACKGROUND_DEPTH:
            point = unproject(camera, viewport, pixel, depth)
            surface_t = float(np.dot(point - origin, direction))
        hit = slice_hit(scene.state.slices, volume.spacing, volume.data.shape, origin - np.asarray(volume.origin),
                        direction)
        if hit is not None and (surface_t is None or hit[0] < surface_t):
            return probe_of(volume, origin + hit[0] * direction, f"slice {'xyz'[hit[1]]}")
        if surface_t is None:
            return None
        return probe_of(volume, point, "surface")

    def _ensure(self, size: tuple[int, int]) -> None:
        if size == self._size:
            return
        self._release_framebuffer()
        self._framebuffer = self.ctx.framebuffer(depth_attachment=self.ctx.depth_renderbuffer(size))
        self._size = size

    def _vao(self, mesh) -> moderngl.VertexArray:
        key = (mesh.vertex_buffer, mesh.index_buffer)
        if key not in self._vaos:
            self._vaos[key] = self.ctx.vertex_array(self.program, [(mesh.vertex_buffer, vertex_format("position"),
                                                                    "in_position")],
                                                    index_buffer=mesh.index_buffer, index_element_size=4)
        return self._vaos[key]

    def _keep(self, keys) -> None:
        for key in [key for key in self._vaos if key not in keys]:
            self._vaos.pop(key).release()

    def _release_framebuffer(self) -> None:
        if self._framebuffer is not None:
            self._framebuffer.depth_attachment.release()
            self._framebuffer.release()
            self._framebuffer, self._size = None, None

    def release(self) -> None:
        """Free the picking framebuffer, the meshes' vertex arrays and the program."""
        self._keep(set())
        self._release_framebuffer()
        self.program.release()


def _bind(framebuffer) -> None:
    """Bind `framebuffer` again, unless it has been released since (moderngl leaves a released one as the
    context's `fbo`; whoever draws next binds their own target, as the window and the headless viewer do)."""
    try:
        framebuffer.use()
    except AttributeError:
        pass

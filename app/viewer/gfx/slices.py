"""Slice planes through the volume, a clip plane, and the 2-D view of the active slice.

Three axis-aligned planes (x, y, z = array axes 0, 1, 2) show the data through a
colour map (from the `cmap` library) with a window/level, as medical viewers do:
values from centre - window/2 to centre + window/2 span the map (model/slices.py).  The isocurve at
the current level is drawn on each slice in the fragment shader (slice.frag), by
marching squares on the pixel's own grid square: the same vertices (linear along
sign-changing edges, ties moved off grid points) and the same rule on ambiguous
squares (inside corners separated, Montani 1994) as the 3-D extractor uses on a
cell face, so the curve on a slice at a grid index is exactly where the mesh
crosses that plane.  In the shader rather than by `find_contours` on the CPU
because it costs nothing per level: dragging the slider moves every curve with
no CPU work and no upload.

The clip plane hides the surface on one side of an axis-aligned plane (hardware
clip distance in mesh.vert) and the cut is capped by the slice at the clip
position, drawn only inside the object (so the surface beyond the cut still shows
around it).  `SliceSettings` (model/slices.py) is what the panel and the command line change
(through ViewerState); `SliceRenderer` owns the GL objects that draw it.
"""
from __future__ import annotations

import moderngl
import numpy as np

from ...core.layout import EDGE_MARGIN
from ...resources import shader_source
from ..model.colormaps import LUT_SIZE, colormap_rgba
from ..model.slices import SliceScene
from .label_scene import LabelCaps

INSET_FRACTION = 0.34     # the 2-D view's longer side, as a fraction of the scene's shorter side
INSET_MARGIN = 10         # pixels from the scene's bottom-right corner
INSET_BORDER = 2          # pixels of frame around it
GL_CLIP_DISTANCE0 = 0x3000


def colormap_rgba8(name: str) -> np.ndarray:
    """(LUT_SIZE, 4) uint8 RGBA of the `cmap` colour map `name`; ValueError for an unknown name."""
    return np.clip(np.round(colormap_rgba(name) * 255), 0, 255).astype(np.uint8)


def slice_image(data: np.ndarray, axis: int, position: float) -> np.ndarray:
    """The plane at index `position` along `axis` as float32 (rows: the lower remaining axis);
    a fractional position interpolates linearly between the two planes around it."""
    below = min(int(np.floor(position)), data.shape[axis] - 1)
    t = position - below
    image = np.take(data, below, axis=axis).astype(np.float32)
    if t > 0:
        image += np.float32(t) * (np.take(data, below + 1, axis=axis).astype(np.float32) - image)
    return np.ascontiguousarray(image)


def plane_corners(shape, spacing, axis: int, position: float, flat: bool = False,
                  origin=(0.0, 0.0, 0.0)) -> np.ndarray:
    """4 vertices (x, y, z, row, column) of the plane, as a triangle strip.  Rows run along the lower of
    the two other axes, columns along the higher.  `flat`: positions in the 2-D view's own plane
    (rows right, columns up, in world units); else in the scene, index 0 at `origin` (Volume.origin)."""
    rows_axis, columns_axis = (a for a in range(3) if a != axis)
    rows, columns = shape[rows_axis] - 1, shape[columns_axis] - 1
    vertices = []
    for row, column in ((0, 0), (rows, 0), (0, columns), (rows, columns)):
        if flat:
            point = [row * spacing[rows_axis], column * spacing[columns_axis], 0.0]
        else:
            point = [0.0, 0.0, 0.0]
            point[axis] = position * spacing[axis]
            point[rows_axis], point[columns_axis] = row * spacing[rows_axis], column * spacing[columns_axis]
            point = [p + o for p, o in zip(point, origin)]
        vertices.append([*point, row, column])
    return np.array(vertices, "f4")


class SliceRenderer:
    """Owns the slice program, the colour map's texture and one texture per plane on show."""

    def __init__(self, ctx: moderngl.Context):
        self.ctx = ctx
        self.program = ctx.program(vertex_shader=shader_source("slice.vert"),
                                   fragment_shader=shader_source("slice.frag", {"EDGE_MARGIN": float(EDGE_MARGIN)}))
        self.quad = ctx.buffer(reserve=4 * 5 * 4)
        self.vao = ctx.vertex_array(self.program, [(self.quad, "3f 2f", "in_position", "in_voxel")])
        self._lut_name: str | None = None
        self.lut = ctx.texture((LUT_SIZE, 1), 4)
        self.lut.repeat_x = self.lut.repeat_y = False
        # (id of the data, axis, position) -> (the data, its texture): the planes drawn last frame.
        self._planes: dict[tuple[int, int, float], tuple[np.ndarray, moderngl.Texture]] = {}
        self.label_caps: LabelCaps | None = None   # a label map's cut, in its labels' colours (label_scene.py)

    def _texture(self, data: np.ndarray, axis: int, position: float) -> moderngl.Texture:
        key = (id(data), axis, position)
        if key not in self._planes:   # the data is kept with its texture, so its id stays its own
            image = slice_image(data, axis, position)
            texture = self.ctx.texture(image.shape[::-1], 1, image, dtype="f4")
            texture.filter = moderngl.NEAREST, moderngl.NEAREST
            self._planes[key] = (data, texture)
        return self._planes[key][1]

    def _release_planes(self, keep=()) -> None:
        for key in [k for k in self._planes if k not in keep]:
            self._planes.pop(key)[1].release()

    def _draw_plane(self, scene: SliceScene, axis: int, position: float, flat: bool, cap: bool = False) -> None:
        self._texture(scene.data, axis, position).use(0)
        self.program["u_cap"].value = cap
        self.quad.write(plane_corners(scene.data.shape, scene.spacing, axis, position, flat, scene.origin).tobytes())
        self.vao.render(moderngl.TRIANGLE_STRIP)

    def _set_uniforms(self, scene: SliceScene, view: bytes, projection: bytes) -> None:
        settings = scene.settings
        if settings.colormap != self._lut_name:
            self.lut.write(colormap_rgba8(settings.colormap).tobytes())
            self._lut_name = settings.colormap
        self.lut.use(1)
        program = self.program
        program["u_view"].write(view)
        program["u_projection"].write(projection)
        program["u_slice"].value = 0
        program["u_colormap"].value = 1
        program["u_window"].value = settings.window
        program["u_level"].value = settings.centre   # the shader's name for the window's centre
        program["u_iso"].value = scene.iso
        program["u_inside_above"].value = scene.gradient_direction == "descent"   # the shader's encoding
        program["u_curve_color"].value = tuple(scene.curve_color)

    def draw(self, scene: SliceScene | None, view: bytes, projection: bytes, caps: bool = True) -> None:
        """The shown slices and the clip's cut (with `caps`), in the 3-D view (depth-tested, opaque)."""
        planes = scene.settings.planes(caps) if scene is not None else []
        inset = scene.settings.inset_axis() if scene is not None else None
        keep = {(id(scene.data), axis, position) for axis, position, _ in planes} if scene is not None else set()
        if inset is not None:
            keep.add((id(scene.data), inset, float(scene.settings.index[inset])))
        self._release_planes(keep)
        if not planes:
            return
        self._set_uniforms(scene, view, projection)
        for axis, position, cap in planes:
            if cap and scene.label_caps is not None:
                self.label_caps = self.label_caps or LabelCaps(self.ctx)
                self.label_caps.draw(scene, axis, position, view, projection)
            else:
                self._draw_plane(scene, axis, position, flat=False, cap=cap)

    def draw_inset(self, scene: SliceScene | None, viewport: tuple[int, int, int, int]) -> None:
        """The active slice facing the viewer, in a framed box at the bottom right of `viewport`."""
        axis = scene.settings.inset_axis() if scene is not None else None
        if axis is None:
            return
        box = inset_box(scene.data.shape, scene.spacing, axis, viewport)
        x, y, width, height = box
        ctx = self.ctx
        ctx.disable(moderngl.DEPTH_TEST)
        ctx.clear(0.65, 0.65, 0.65, 1.0, viewport=(x - INSET_BORDER, y - INSET_BORDER,
                                                   width + 2 * INSET_BORDER, height + 2 * INSET_BORDER))
        ctx.viewport = box
        rows_axis, columns_axis = (a for a in range(3) if a != axis)
        extent = ((scene.data.shape[rows_axis] - 1) * scene.spacing[rows_axis],
                  (scene.data.shape[columns_axis] - 1) * scene.spacing[columns_axis])
        from pyrr import matrix44
        projection = matrix44.create_orthogonal_projection(0, extent[0], 0, extent[1], -1, 1, dtype="f4")
        self._set_uniforms(scene, np.eye(4, dtype="f4").tobytes(), projection.tobytes())
        self._draw_plane(scene, axis, float(scene.settings.index[axis]), flat=True)
        ctx.viewport = viewport
        ctx.enable(moderngl.DEPTH_TEST)

    def release(self) -> None:
        """Free the slices' textures, the label caps, the quad, the colour map and the program."""
        self._release_planes()
        if self.label_caps is not None:
            self.label_caps.release()
        for obj in (self.vao, self.quad, self.lut, self.program):
            obj.release()


def inset_box(shape, spacing, axis: int, viewport) -> tuple[int, int, int, int]:
    """The 2-D view's pixels (x, y, width, height; y up) in `viewport`: the slice's aspect, its longer
    side INSET_FRACTION of the viewport's shorter side, at the bottom right."""
    rows_axis, columns_axis = (a for a in range(3) if a != axis)
    extent = (max((shape[rows_axis] - 1) * spacing[rows_axis], 1e-9),
              max((shape[columns_axis] - 1) * spacing[columns_axis], 1e-9))
    longest = INSET_FRACTION * min(viewport[2], viewport[3])
    width = max(int(round(longest * extent[0] / max(extent))), 1)
    height = max(int(round(longest * extent[1] / max(extent))), 1)
    return (viewport[0] + viewport[2] - INSET_MARGIN - width, viewport[1] + INSET_MARGIN, width, height)

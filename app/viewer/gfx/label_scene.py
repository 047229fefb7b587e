"""Label maps on screen: each label's surface uploaded as a `GpuMesh`, kept while its label map is on show,
and the clip's cut drawn in the labels' colours.

`LabelMeshes` is the GPU side of a `LabelMap` (model/labels.py): it extracts every label's surface once
per label map (`extractions` counts it) and keeps them all, so a label shown, hidden or faded changes
only the draw list (`drawn`), never a mesh.  With `previews` (the window), a label map whose surfaces are
too many triangles to draw at once on a software renderer is also kept as coarse surfaces (every
`preview_step`-th sample), which the scene draws for the frames right after a label is shown, hidden or
faded, until it rests (preview_pacing.py's REST_S), as a dragged level is previewed.  `LabelCaps` draws the
clip's cut (label_cap.frag): the labels' index on the grid plane nearest the clip, looked up in a table
of their colours, each label's part in its colour as its surface is cut.  `label_scene` is the one-shot
upload of `label_surfaces`' result for a caller that owns its buffers.
"""
from __future__ import annotations

import moderngl
import numpy as np

from ...gpu.context import has_compute
from ...gpu.mesh import GpuMesh
from ...labels import label_colors, label_surfaces, labels_of
from ...resources import shader_source
from ..model.labels import LabelLayer, LabelMap
from ..model.slices import SliceScene
from .preview_pacing import REST_S

PREVIEW_TRIANGLES = 250_000   # label surfaces above this many triangles get coarse twins for the frames after a toggle
TABLE_WIDTH = 1024   # the colour table's texture is this wide, as many rows as the labels need
PLANE_UNIT, TABLE_UNIT = 5, 6   # texture units (the slices use 0 and 1, the surfaces' looks 3 and 4)


def label_scene(ctx, surfaces: dict) -> list[tuple[int, GpuMesh, tuple[float, float, float]]]:
    """(label, mesh on the GPU, RGB colour) per label of `label_surfaces`' result, in label order.
    The caller owns the buffers (release them with `release_scene`)."""
    scene = []
    try:
        for label, color in zip(sorted(surfaces), label_colors(len(surfaces))):
            scene.append((label, GpuMesh.upload(ctx, *surfaces[label], float(label)), tuple(map(float, color))))
    except BaseException:   # out of GPU memory half-way: nothing half-made is left behind
        release_scene(scene)
        raise
    return scene


def release_scene(scene) -> None:
    """Free the GPU buffers of a `label_scene` result."""
    for _, mesh, _ in scene:
        mesh.release()


class LabelMeshes:
    """Every label's surface of the label map on show, on the GPU, by label."""

    def __init__(self, ctx: moderngl.Context, previews: bool = False):
        self.ctx = ctx
        self.previews = previews
        self.meshes: dict[int, GpuMesh] = {}
        self.coarse: dict[int, GpuMesh] = {}   # with previews, of a big label map: every preview_step-th sample
        self.preview_step = 1
        self.serial: int | None = None   # the label map (LabelMap.serial) they are of
        self.extractions = 0             # label maps extracted so far: a toggle makes none
        self._look = None                # the labels' (label, visible, opacity) last frame
        self._rest_s = REST_S            # how long they have not changed

    def follow(self, labels: LabelMap, volume) -> None:
        """Extract `volume`'s labels when another label map is put on show; release them when none is.
        A failed extraction hides the label map (the levels come back) and raises."""
        if labels.serial == self.serial and labels:
            return
        self.release()
        if not labels:
            return
        backend = "gpu" if has_compute(self.ctx) else "cpu"
        try:
            data = labels_of(volume)
            surfaces = label_surfaces(data, spacing=volume.spacing, backend=backend)
            self.meshes = {label: mesh for label, mesh, _ in label_scene(self.ctx, surfaces)}
            triangles = sum(len(faces) for _, faces, _ in surfaces.values())
            if self.previews and triangles > PREVIEW_TRIANGLES:
                # Triangles fall with the square of the step: the coarse ones fit the budget.
                step = int(np.ceil(np.sqrt(triangles / PREVIEW_TRIANGLES)))
                coarse = label_surfaces(data[::step, ::step, ::step],
                                        spacing=tuple(s * step for s in volume.spacing), backend=backend)
                self.coarse = {label: mesh for label, mesh, _ in label_scene(self.ctx, coarse)}
                self.preview_step = step
        except BaseException:
            self.release()
            labels.hide()
            raise
        self.extractions += 1
        self.serial = labels.serial

    def follow_look(self, labels: LabelMap, dt_seconds: float, wait: bool) -> None:
        """How long the label map's looks have rested: coarse label surfaces are drawn until REST_S (`resting`)."""
        look = tuple((layer.label, layer.visible, layer.opacity) for layer in labels.layers) if labels else None
        if wait:
            self._rest_s = REST_S
        elif look != self._look and self._look is not None and look is not None:
            self._rest_s = 0.0
        else:
            self._rest_s += dt_seconds
        self._look = look

    @property
    def resting(self) -> bool:
        """Whether the looks have rested REST_S: the full surfaces are drawn, not the coarse twins."""
        return self._rest_s >= REST_S

    def drawn(self, labels: LabelMap, coarse: bool = False) -> list[tuple[GpuMesh, LabelLayer]]:
        """The visible labels' meshes and layers (their colours and opacities: the renderer's looks); with
        `coarse`, their coarse twins where they have them (a label too small for the coarse grid keeps its own)."""
        kept = self.coarse if coarse else self.meshes
        return [(kept.get(layer.label, self.meshes[layer.label]), layer) for layer in labels.visible()
                if layer.label in self.meshes]

    def triangles(self, label: int) -> int:
        """The triangles of label `label`'s full surface (0 where it has none yet)."""
        mesh = self.meshes.get(label)
        return mesh.n_triangles if mesh is not None else 0

    def counts(self, labels: LabelMap) -> tuple[int, int, int]:
        """(labels shown, vertices, triangles) of the visible labels' surfaces: the stats of what is drawn."""
        shown = [self.meshes[layer.label] for layer in labels.visible() if layer.label in self.meshes]
        return len(shown), sum(m.n_vertices for m in shown), sum(m.n_triangles for m in shown)

    def release(self) -> None:
        """Free every label's meshes, full and coarse, and forget which label map they were made for."""
        for mesh in [*self.meshes.values(), *self.coarse.values()]:
            mesh.release()
        self.meshes, self.coarse, self.preview_step, self.serial = {}, {}, 1, None


def plane_indices(data: np.ndarray, labels: np.ndarray, axis: int, position: float) -> tuple[int, np.ndarray]:
    """(the grid index nearest `position` along `axis`, that plane of `data` as float32 indices into
    `labels` (sorted) plus one: 0 where a sample's label is not among them, the background)."""
    index = int(np.clip(np.floor(position + 0.5), 0, data.shape[axis] - 1))
    plane = np.take(data, index, axis=axis)
    found = np.clip(np.searchsorted(labels, plane), 0, max(len(labels) - 1, 0))
    hit = labels[found] == plane if len(labels) else np.zeros(plane.shape, bool)
    return index, np.ascontiguousarray(np.where(hit, found + 1, 0).astype(np.float32))


def cap_corners(shape, spacing, axis: int, position: float, origin=(0.0, 0.0, 0.0)) -> np.ndarray:
    """4 vertices (x, y, z, row, column) of the clip's plane, half a sample beyond the volume on every
    side (where the labels' surfaces close), as a triangle strip; index 0 at `origin` (Volume.origin: where
    the labels' surfaces are drawn and the clip cuts them, as slices.py's plane_corners)."""
    rows_axis, columns_axis = (a for a in range(3) if a != axis)
    vertices = []
    for row in (-0.5, shape[rows_axis] - 0.5):
        for column in (-0.5, shape[columns_axis] - 0.5):
            point = [0.0, 0.0, 0.0]
            point[axis] = position * spacing[axis]
            point[rows_axis], point[columns_axis] = row * spacing[rows_axis], column * spacing[columns_axis]
            vertices.append([*(p + o for p, o in zip(point, origin)), row, column])
    return np.array(vertices, "f4")[[0, 2, 1, 3]]


class LabelCaps:
    """Draws the clip's cut of a label map (SliceScene.label_caps) in the labels' colours."""

    def __init__(self, ctx: moderngl.Context):
        self.ctx = ctx
        self.program = ctx.program(vertex_shader=shader_source("slice.vert"),
                                   fragment_shader=shader_source("label_cap.frag", {"TABLE_WIDTH": TABLE_WIDTH}))
        self.quad = ctx.buffer(reserve=4 * 5 * 4)
        self.vao = ctx.vertex_array(self.program, [(self.quad, "3f 2f", "in_position", "in_voxel")])
        # (the data, which plane and labels, its texture): the data is kept so its id stays its own
        self._plane: tuple[np.ndarray, tuple, moderngl.Texture] | None = None
        self._table: tuple[bytes, moderngl.Texture] | None = None

    def draw(self, scene: SliceScene, axis: int, position: float, view: bytes, projection: bytes) -> None:
        """Draw the clip plane's cut across `axis` at `position` in each label's colour and opacity
        (`scene.label_caps`), with the given view and projection matrices."""
        labels, rgba = scene.label_caps
        self._plane_texture(scene.data, labels, axis, position).use(PLANE_UNIT)
        self._table_texture(rgba).use(TABLE_UNIT)
        program = self.program
        program["u_view"].write(view)
        program["u_projection"].write(projection)
        program["u_plane"].value = PLANE_UNIT
        program["u_table"].value = TABLE_UNIT
        self.quad.write(cap_corners(scene.data.shape, scene.spacing, axis, position, scene.origin).tobytes())
        self.vao.render(moderngl.TRIANGLE_STRIP)

    def _plane_texture(self, data, labels, axis, position) -> moderngl.Texture:
        index = int(np.clip(np.floor(position + 0.5), 0, data.shape[axis] - 1))
        key = (axis, index, labels.tobytes())
        if self._plane is None or self._plane[0] is not data or self._plane[1] != key:
            _, image = plane_indices(data, labels, axis, position)
            texture = self.ctx.texture(image.shape[::-1], 1, image, dtype="f4")
            texture.filter = moderngl.NEAREST, moderngl.NEAREST
            self._release_plane()
            self._plane = (data, key, texture)
        return self._plane[2]

    def _table_texture(self, rgba: np.ndarray) -> moderngl.Texture:
        key = rgba.tobytes()
        if self._table is None or self._table[0] != key:
            rows = -(-(len(rgba) + 1) // TABLE_WIDTH)
            table = np.zeros((rows * TABLE_WIDTH, 4), np.float32)   # index 0: the background, no cut
            table[1:len(rgba) + 1] = rgba
            texture = self.ctx.texture((TABLE_WIDTH, rows), 4, table.tobytes(), dtype="f4")
            texture.filter = moderngl.NEAREST, moderngl.NEAREST
            if self._table is not None:
                self._table[1].release()
            self._table = (key, texture)
        return self._table[1]

    def _release_plane(self) -> None:
        if self._plane is not None:
            self._plane[2].release()
            self._plane = None

    def release(self) -> None:
        """Free the plane's and the colour table's textures, the quad and the program."""
        self._release_plane()
        if self._table is not None:
            self._table[1].release()
            self._table = None
        for obj in (self.vao, self.quad, self.program):
            obj.release()

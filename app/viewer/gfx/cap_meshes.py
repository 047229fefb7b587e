"""The caps of "closed at the border" on the GPU: each visible level's caps (one_shot.border_caps) uploaded in the
vertex layout the renderer draws, made again when the level, the cells, the object's side or the volume
change, and drawn in their level's look after the levels (GpuScene.drawn).  A label map's surfaces are
closed already (labels.py): they get none.
"""
from __future__ import annotations

from ...one_shot import border_caps
from .cpu_surface import CpuMesh
from .renderer import SurfaceLook


class CapMeshes:
    """The caps of "closed at the border" of each visible level, uploaded and kept until what they were made of changes.
    """

    def __init__(self, ctx):
        self.ctx = ctx
        self._meshes: dict = {}   # Level -> (what its caps were made of, CpuMesh)

    def drawn(self, state, color_by=None) -> list:
        """(GpuMesh, SurfaceLook) of the caps of the visible levels while `state.closed`, else none."""
        if not getattr(state, "closed", False) or state.volume is None or state.labels:
            self.release()
            return []
        volume, levels = state.volume, state.levels
        for level in [level for level in self._meshes if level not in levels.items]:
            self._meshes.pop(level)[1].release()
        shown = []
        for i, level in enumerate(levels):
            if not level.visible:
                continue
            mesh = self._mesh(level, volume, state.mesh_options.cells)
            if mesh.n_triangles:
                shown.append((mesh.mesh, SurfaceLook(levels.color(i, state.style.front_color), level.opacity,
                                                     color_by, volume.origin)))
        return shown

    def _mesh(self, level, volume, cells: str) -> CpuMesh:
        key = (level.value, cells, volume.gradient_direction, id(volume))
        made = self._meshes.get(level)
        if made is not None and made[0] == key:
            return made[1]
        mesh = made[1] if made is not None else CpuMesh(self.ctx)
        arrays = border_caps(volume.checked.data, level.value, volume.spacing, volume.gradient_direction,
                      volume.value_range, cells)
        mesh.take(arrays, level.value, 0.0)
        self._meshes[level] = (key, mesh)
        return mesh

    def release(self) -> None:
        """Free every level's caps on the GPU."""
        for _, mesh in self._meshes.values():
            mesh.release()
        self._meshes.clear()

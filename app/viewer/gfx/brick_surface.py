"""The GL side of a volume shown in bricks (model/bricks.py): the coarse mesh with the bricks at full
resolution cut out of it, each of those bricks' meshes, and the skirts where the two levels meet.

`follow` brings the buffers in line with the model once a frame: the selected level's coarse mesh (the
scene's surface, at rest at the model's value) is read back once and split by brick (each triangle's cell,
big/chunked.py edges_of: a coarse cell lies in one brick); whenever the set of bricks at full resolution
changes, the coarse remainder is drawn again without them: its vertices and its triangles, in order of their
brick, are uploaded once per coarse mesh, and it is drawn as ranges of those, a range per run of bricks not
refined (nothing is written again), a new brick's mesh is uploaded, a dropped one released, and the
skirts made again: on the coarse side of each face between a coarse and a refined brick, and on the
refined side (core/skirts.py), one coarse step deep.  With every brick refined there is
no coarse remainder and no skirt: the bricks' meshes are the chunked extractor's, the whole volume's mesh.

This class owns every GL object it makes and `release` frees them all.
"""
from __future__ import annotations

import numpy as np

from ...big.chunked import edges_of
from ...core.skirts import edge_keys, rim_of, skirt
from ...gpu.context import is_software_renderer
from ...gpu.memory import give_back_freed_memory
from ...gpu.mesh import GpuMesh, OwnedMesh, vertex_records


class CoarseSplit:
    """The coarse mesh on the CPU, each triangle's brick (`brick`, flat index), the triangles in order of their
    brick (`by_brick`; brick b's are `starts[b]` to `starts[b + 1]` of them), and its edges between triangles of
    two bricks (`rim`: each side's edge, with `own` and `across` its brick and the other).  A triangle's brick is
    its coarse cell's; its vertices (and the rim's) are moved by `origin`, where the coarse view's samples lie in
    the scene (Volume.origin: a pyramid level off the full level's grid), so it is drawn where the file puts it."""

    def __init__(self, arrays, spacing, step: int, cells: int, grid, origin=(0.0, 0.0, 0.0)):
        verts, faces = arrays[0], np.asarray(arrays[1], dtype=np.int64)
        if any(origin):
            arrays = ((np.asarray(verts, np.float64) + origin).astype(np.float32), *arrays[1:])
        self.arrays = arrays
        if not len(faces):
            self.brick = self.by_brick = np.zeros(0, dtype=np.int64)
            self.starts = np.zeros(int(np.prod(grid)) + 1, dtype=np.int64)
            self.rim, self.own, self.across = rim_of(*arrays, edges=np.zeros((0, 2))), self.brick, self.brick
            return
        points, _ = edges_of(verts, spacing)
        cells_of = points[faces].min(axis=1) * step   # a triangle's cell (as extract_box), in full samples
        index = np.minimum(cells_of // cells, np.asarray(grid) - 1)
        self.brick = np.ravel_multi_index(index.T, grid)
        # the triangles sorted by brick (stable: each brick's in the mesh's order), and where each brick's start
        self.by_brick = np.argsort(self.brick, kind="stable")
        self.starts = np.searchsorted(self.brick[self.by_brick], np.arange(int(np.prod(grid)) + 1))
        # every directed edge; an edge whose two triangles lie in two bricks is on a face between them
        key = edge_keys(faces)
        order = np.argsort(key, kind="stable")
        pair = np.flatnonzero(key[order][1:] == key[order][:-1])
        first, second = order[pair], order[pair + 1]
        split = self.brick[first // 3] != self.brick[second // 3]
        first, second = first[split], second[split]
        sides = np.concatenate([first, second])
        self.own = self.brick[sides // 3]
        self.across = self.brick[np.concatenate([second, first]) // 3]
        self.rim = rim_of(*arrays, edges=np.stack(np.divmod(sides, 3), axis=1))


class BrickSurface:
    """The buffers of the bricks on show; `meshes` what the renderer draws in the selected level's place while
    `drawing`."""

    def __init__(self, ctx):
        self.ctx = ctx
        self.drawing = False
        self._view = None            # the model followed
        self._surface = None         # the surface whose coarse mesh is split
        self._coarse_key = None
        self._split: CoarseSplit | None = None
        self._serial = None
        self._coarse_vertices = None               # the coarse mesh's vertex records (a buffer, once a split)
        self._coarse_triangles = None              # and its triangles in order of their brick (a buffer, once)
        self._coarse: list[GpuMesh] = []           # the runs of those of bricks not refined (views of them)
        self._fine: dict[tuple, OwnedMesh] = {}    # each refined brick's mesh
        # each refined brick's skirts, and which of the bricks across its faces were refined when they were
        # made: a brick's arrival makes again only its own and its neighbours' skirts
        self._fine_skirts: dict[tuple, tuple[bytes, OwnedMesh | None]] = {}
        self._skirts: OwnedMesh | None = None      # the coarse side's skirts along every seam

    @staticmethod
    def coarse_of(surface, state):
        """(vertices, triangles) of the selected level's coarse mesh where it is on show at rest at the state's
        value (what the model refines), else None."""
        if surface is None or state.bricks is None or surface.shown_step != 1:
            return None
        shown = surface.shown
        if shown.level is None or float(shown.level) != float(state.iso):
            return None
        return shown.n_vertices, shown.n_triangles

    @property
    def meshes(self) -> list[GpuMesh]:
        """The coarse remainder, the refined bricks and the skirts (those with triangles)."""
        parts = [*self._coarse, *self._fine.values(), self._skirts, *(m for _, m in self._fine_skirts.values())]
        return [mesh for mesh in parts if mesh is not None and mesh.n_triangles]

    def follow(self, view, surface, coarse_spacing, origin=(0.0, 0.0, 0.0)) -> None:
        """Bring the buffers in line with `view` (a BrickView, or None) over `surface`'s coarse mesh, whose
        vertices are placed at `origin` (Volume.origin of the coarse view)."""
        if view is None or not view.active or surface is None:
            self.clear()
            return
        key = (view.key, surface.shown.n_vertices, surface.shown.n_triangles)
        if view is not self._view or surface is not self._surface or key != self._coarse_key:
            self.clear()
            if any(mesh.arrays is None for mesh in view.meshes.values()):
                view.forget()   # meshes whose buffers were let go with the old coarse mesh: made again
            self._view, self._surface, self._coarse_key = view, surface, key
            layout = view.layout
            self._split = CoarseSplit(surface.shown.read_mesh(), coarse_spacing, layout.step, layout.cells,
                                      view.grid, origin)
        if view.serial != self._serial:
            self._rebuild(view)
            self._serial = view.serial
        self.drawing = True

    def _rebuild(self, view) -> None:
        flat = view.flat
        refined = np.zeros(len(view.bricks), dtype=bool)
        refined[[flat[index] for index in view.meshes]] = True
        for index in [index for index in self._fine if index not in view.meshes]:
            self._fine.pop(index).release()
        for index in [index for index in self._fine_skirts if index not in view.meshes]:
            self._drop_skirt(index)
        taken = 0
        for index, mesh in view.meshes.items():
            if index not in self._fine and mesh.arrays is not None:
                uploaded = _upload(self.ctx, mesh.arrays)
                if uploaded is not None:   # a brick the level does not cross has no mesh
                    self._fine[index] = uploaded
                view.uploaded(index)
                taken += 1
        depth = view.layout.step * max(view.volume.spacing)
        split = self._split
        self._coarse_remainder(split, ~refined)
        self._replace("_skirts", skirt(split.rim.subset(~refined[split.own] & refined[split.across]), depth))
        for index, mesh in view.meshes.items():   # the refined side: where the brick across is coarse
            across = refined[mesh.across]
            made = self._fine_skirts.get(index)
            if made is None or made[0] != across.tobytes():
                self._drop_skirt(index)
                self._fine_skirts[index] = (across.tobytes(), _upload(self.ctx, skirt(mesh.rim.subset(~across),
                                                                                      depth)))
        if taken and is_software_renderer(self.ctx):   # the bricks' arrays and their extraction's work arrays
            give_back_freed_memory()   # are gone: their pages too, where they count in the budget (llvmpipe)

    def _drop_skirt(self, index) -> None:
        _, mesh = self._fine_skirts.pop(index, (None, None))
        if mesh is not None:
            mesh.release()

    def _coarse_remainder(self, split, kept) -> None:
        """The coarse mesh's triangles in the bricks `kept` (those not refined: a flag per brick) as the coarse
        remainder: its vertices and its triangles in order of their brick uploaded on the first call for this
        split, and on each a view of every run of kept bricks' triangles (no buffer written again)."""
        verts, faces, normals, values = split.arrays
        self._coarse = []
        if not len(faces):
            return
        if self._coarse_vertices is None:
            self._coarse_vertices = self.ctx.buffer(vertex_records(verts, normals, values).tobytes())
            ordered = np.ascontiguousarray(faces[split.by_brick], np.uint32)
            self._coarse_triangles = self.ctx.buffer(ordered.tobytes())
        edges = np.diff(np.concatenate(([0], kept.astype(np.int8), [0])))
        for first, end in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)):   # runs [first, end)
            start, stop = int(split.starts[first]), int(split.starts[end])
            if stop > start:
                self._coarse.append(GpuMesh(self._coarse_vertices, self._coarse_triangles, len(verts), stop - start,
                                            first_triangle=start))

    def _replace(self, name: str, arrays) -> None:
        old = getattr(self, name)
        setattr(self, name, None)
        if old is not None:
            old.release()
        if arrays is not None and len(arrays[1]):
            setattr(self, name, _upload(self.ctx, arrays))

    def clear(self) -> None:
        """Nothing drawn in bricks: every buffer released."""
        self.drawing = False
        if (self._view is None and self._coarse_vertices is None and self._skirts is None and not self._fine
                and not self._fine_skirts):
            return   # nothing held (a volume shown whole: called every frame)
        self._view = self._surface = self._coarse_key = self._split = self._serial = None
        self._coarse = []
        for buffer in (self._coarse_vertices, self._coarse_triangles):
            if buffer is not None:
                buffer.release()
        self._coarse_vertices = self._coarse_triangles = None
        self._replace("_skirts", None)
        for mesh in self._fine.values():
            mesh.release()
        self._fine.clear()
        for index in list(self._fine_skirts):
            self._drop_skirt(index)

    def release(self) -> None:
        """Free every GL object of the bricks."""
        self.clear()


def _upload(ctx, arrays) -> OwnedMesh | None:
    verts, faces, normals, values = arrays
    if not len(faces):
        return None
    return GpuMesh.upload(ctx, verts, faces, normals, values)

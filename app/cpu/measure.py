"""What a surface measures: area, enclosed volume, connected pieces and bounding box, from its mesh.

The mesh is in world units (millimetres for a scan with a world frame; index x spacing otherwise).
Enclosed volume is the divergence theorem over the triangles (a sum of signed tetrahedra from the
origin), exact for a closed, outward-wound surface; a surface that leaves the volume is open there
(`open_edges`), and what its triangles enclose is then not the object's volume (`export --closed`
caps it).  Pieces are found by
shared vertices: hooking each vertex to the smallest label among its neighbours, then pointer
jumping, until nothing changes (a few rounds: the rounds grow with the log of a piece's size).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np


@dataclass(frozen=True)
class SurfaceMeasure:
    """A mesh's measures in its world units: area, enclosed volume, connected pieces and their volumes, bounding box,
    open edges, Euler characteristic and genus."""
    area: float                      # world units^2 (mm^2)
    volume: float                    # world units^3 (mm^3) enclosed by the triangles (the object's, if closed)
    components: int                  # connected pieces
    largest_component_volume: float  # world units^3 of the piece enclosing the most
    bbox_min: tuple[float, float, float]
    bbox_max: tuple[float, float, float]
    open_edges: int                  # edges used by one triangle: where the surface is not closed
    smallest_component_volume: float = 0.0   # of the piece enclosing the least (a cavity: below 0)
    turned: bool = False             # measured with its triangles facing the other way (`inside_out`)
    # Pieces enclosing less than nothing are cavities (a hollow's inner wall, an air pocket): their count and
    # what they take away (<= 0); the rest are solid pieces and what they enclose.  volume = the two summed.
    cavities: int = 0
    cavity_volume: float = 0.0
    solids: int = 0
    solid_volume: float = 0.0
    # Topology: V - E + F over the vertices the triangles use; for a closed surface of `components` pieces,
    # 2 * components - euler = 2 * genus (the handles, tunnels through the object, of all its pieces summed).
    euler: int = 0

    @property
    def genus(self) -> int | None:
        """The handles of a closed surface (a ball 0, a torus 1, a pretzel 2; summed over its pieces), None
        where it is open (it leaves the volume: no genus without `export --closed`'s caps)."""
        if self.open_edges or not self.components:
            return None
        return (2 * self.components - self.euler) // 2

    @property
    def inside_out(self) -> bool:
        """Closed, and enclosing less than nothing: its triangles face into what they enclose, so the object
        is the other side of the level (the volume's side, `Volume.gradient_direction`, is the wrong one:
        a signed distance taken as a density): a bounded object's cavities never outweigh it."""
        return self.open_edges == 0 and self.volume < 0

    def turn(self) -> SurfaceMeasure:
        """The measures with the triangles facing the other way: the object on the other side of the level."""
        return replace(self, volume=-self.volume, largest_component_volume=-self.smallest_component_volume,
                       smallest_component_volume=-self.largest_component_volume, turned=not self.turned,
                       cavities=self.solids, cavity_volume=-self.solid_volume, solids=self.cavities,
                       solid_volume=-self.cavity_volume)


def components(n_vertices: int, faces: np.ndarray) -> np.ndarray:
    """A label per vertex, equal for vertices joined through triangles; labels are the pieces' smallest
    vertex index (vertices in no triangle are pieces of their own)."""
    labels = np.arange(n_vertices, dtype=np.int64)
    if not len(faces):
        return labels
    a = np.concatenate([faces[:, 0], faces[:, 1], faces[:, 2]]).astype(np.int64)
    b = np.concatenate([faces[:, 1], faces[:, 2], faces[:, 0]]).astype(np.int64)
    while True:
        before = labels.copy()
        np.minimum.at(labels, a, labels[b])
        np.minimum.at(labels, b, labels[a])
        while True:  # pointer jumping: every vertex to its label's label
            jumped = labels[labels]
            if np.array_equal(jumped, labels):
                break
            labels = jumped
        if np.array_equal(labels, before):
            return labels


def _edge_counts(faces: np.ndarray) -> np.ndarray:
    """How many triangles use each distinct (undirected) edge."""
    edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    return np.unique(edges, axis=0, return_counts=True)[1]


def open_edge_count(faces: np.ndarray) -> int:
    """How many edges of `faces` only one triangle uses: 0 for a closed surface."""
    return int((_edge_counts(faces) == 1).sum())


def euler_characteristic(faces: np.ndarray) -> int:
    """V - E + F of a mesh whose pieces share vertices by index (vertices no triangle uses left out)."""
    faces = np.asarray(faces, np.int64).reshape(-1, 3)
    if not len(faces):
        return 0
    return int(len(np.unique(faces)) - len(_edge_counts(faces)) + len(faces))


def measure_surface(verts: np.ndarray, faces: np.ndarray) -> SurfaceMeasure:
    """The measures of one surface; `verts` (N, 3) in world units, `faces` (M, 3) outward-wound.  A closed
    surface whose triangles face into what they enclose (`inside_out`) is measured turned (`turned` says
    so): the object's volume is positive whichever side of the level it is on."""
    measured = _measured(verts, faces)
    return measured.turn() if measured.inside_out else measured


def _measured(verts: np.ndarray, faces: np.ndarray) -> SurfaceMeasure:
    verts = np.asarray(verts, np.float64)
    faces = np.asarray(faces, np.int64).reshape(-1, 3)
    if not len(faces):
        return SurfaceMeasure(0.0, 0.0, 0, 0.0, (np.nan,) * 3, (np.nan,) * 3, 0)
    p0, p1, p2 = verts[faces[:, 0]], verts[faces[:, 1]], verts[faces[:, 2]]
    centre = verts[faces].reshape(-1, 3).mean(axis=0)  # tetrahedra from near the mesh: less cancellation
    area = 0.5 * np.linalg.norm(np.cross(p1 - p0, p2 - p0), axis=1)
    signed = np.einsum("ij,ij->i", p0 - centre, np.cross(p1 - centre, p2 - centre)) / 6.0
    labels = components(len(verts), faces)
    piece = np.unique(labels[faces[:, 0]], return_inverse=True)[1].reshape(-1)
    volumes = np.bincount(piece, weights=signed)
    used = np.unique(faces)
    edge_counts = _edge_counts(faces)
    return SurfaceMeasure(area=float(area.sum()), volume=float(volumes.sum()), components=len(volumes),
                          largest_component_volume=float(volumes.max()),
                          smallest_component_volume=float(volumes.min()),
                          bbox_min=tuple(float(v) for v in verts[used].min(axis=0)),
                          bbox_max=tuple(float(v) for v in verts[used].max(axis=0)),
                          open_edges=int((edge_counts == 1).sum()),
                          euler=int(len(used) - len(edge_counts) + len(faces)),
                          cavities=int((volumes < 0).sum()), cavity_volume=float(volumes[volumes < 0].sum()),
                          solids=int((volumes > 0).sum()), solid_volume=float(volumes[volumes > 0].sum()))


def in_millimetres(measured: SurfaceMeasure, mm_per_unit: float) -> SurfaceMeasure:
    """`measured` (in the file's length unit) in millimetres: areas times `mm_per_unit` squared, volumes cubed,
    the box times it; the same record where the unit is the millimetre (1)."""
    f = float(mm_per_unit)
    if f == 1.0:
        return measured
    return replace(measured, area=measured.area * f ** 2, volume=measured.volume * f ** 3,
                   largest_component_volume=measured.largest_component_volume * f ** 3,
                   smallest_component_volume=measured.smallest_component_volume * f ** 3,
                   bbox_min=tuple(v * f for v in measured.bbox_min), bbox_max=tuple(v * f for v in measured.bbox_max),
                   cavity_volume=measured.cavity_volume * f ** 3, solid_volume=measured.solid_volume * f ** 3)

"""The mesh modes and which go together: one spec that the Python API, the command line and the viewer
all check a combination with, in one wording per rule.

Modes: the cells marched (cubes or tetrahedra), the topology of cubes (Montani's faces, or the trilinear
interpolant's: `isoscope.core.trilinear_table`), smoothing iterations, sharp features (Extended Marching
Cubes, a feature angle), a mask of cells, and chunks (extraction a box at a time, stitched).
"""
from __future__ import annotations

from dataclasses import dataclass

from .core.trilinear_table import TOPOLOGIES as TOPOLOGIES  # the choices, for the flags, panel and scenes
from .core.trilinear_table import topology_problem
from .errors import IsoscopeError

CELLS = ("cubes", "tetrahedra")


class MeshOptionsError(IsoscopeError, ValueError):
    """Mesh modes that do not go together; the message names the rule."""


@dataclass(frozen=True)
class MeshOptions:
    """A combination of mesh modes (cells, smoothing, sharp features, mask, chunks, topology); `problem` and `check` say
    whether the modes go together."""
    cells: str = "cubes"
    smooth: int = 0
    sharp: float | None = None
    masked: bool = False
    chunked: bool = False
    topology: str = "montani"

    def problem(self) -> str | None:
        """What is wrong with this combination, in the rule's one wording, or None."""
        if self.cells not in CELLS:
            return f"unknown cells {self.cells!r}; use one of {', '.join(CELLS)}"
        topology = topology_problem(self.topology)
        if topology is not None:
            return topology
        if self.topology == "trilinear" and (self.cells != "cubes" or self.sharp is not None or self.masked):
            return ("the trilinear topology decides the ambiguous cells of plain marching cubes: not with "
                    "tetrahedra, sharp features or a mask")
        if self.sharp is not None and self.cells != "cubes":
            return "sharp features are Extended Marching Cubes, a method of cubes: not with tetrahedra"
        if self.sharp is not None and self.smooth:
            return "smoothing would round off the sharp features: use one or the other"
        if self.masked and (self.smooth or self.sharp is not None or self.chunked):
            return "a mask keeps cells of the plain mesh: not with smoothing, sharp features or chunks"
        if self.chunked and (self.smooth or self.sharp is not None or self.cells != "cubes"):
            return ("a chunked extraction makes plain marching cubes of the whole volume a box at a time: "
                    "not with smoothing, sharp features or tetrahedra")
        return None

    def check(self) -> MeshOptions:
        """This combination, or MeshOptionsError naming the rule it breaks."""
        problem = self.problem()
        if problem is not None:
            raise MeshOptionsError(problem)
        return self

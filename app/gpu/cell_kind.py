"""What differs between the kinds of cell the GPU marches: `CellKind`, named by cubes.py and tetra.py.

Passes 1-2 are the same for every kind (`SHARED_PASSES`); the kind names the shaders of passes 3, 4
and 6-8 (extraction.py lists them), each a short ``mc_*.comp`` or ``mt_*.comp`` that includes the
kind's GLSL (its counts and jobs: ``mc_cells.glsl``, ``mc_jobs.glsl`` or ``mt_cells.glsl``,
``mt_jobs.glsl``) and the pass's body that every kind shares (``cells_<pass>.glsl``), compiled with
the kind's `CellKind.defines`.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from ..core.case_table import CaseTable

CASE_TABLE_SHIFT = 10
"""The case-table image is 2^10 texels wide (see mc_case_table.glsl)."""

SHARED_PASSES = {"bricks": "mc_bricks", "dispatch_args": "mc_dispatch_args", "signs": "mc_signs"}
"""The passes every kind of cell runs as they are (by role)."""

OWN_EDGES = 12
"""Slots of an own vertex's job: the most edge vertices one is the mean of (a cell has 12 edges)."""

_UINT_IMAGE_FORMATS = {1: "r32ui", 2: "rg32ui", 4: "rgba32ui"}
_UINT_TYPES = {1: "uint", 2: "uvec2", 3: "uvec3", 4: "uvec4"}


@dataclass(frozen=True)
class CellKind:
    """What differs between cubes and tetrahedra: the shaders of the per-kind passes and the sizes
    of what they write."""
    name: str
    classify: str
    brick_sums: str
    word_offsets: str
    triangles: str
    vertices: str
    job_components: int
    """uints per vertex job (shaders/vertex_jobs.glsl)."""
    count_components: int
    """Components of the per-word counts image."""
    table: Callable[[], CaseTable]
    """The case table it marches by default."""
    job_coordinates: bool = False
    """Whether its vertex jobs hold their sample's coordinates where the grid allows (JOB_COORDINATES)."""
    own_vertices: str | None = None
    """The shader of pass 9, where cells add vertices of their own after every edge vertex (OWN_VERTICES:
    the trilinear topology's, trilinear.py); their counts are summed and scanned on their own."""

    @property
    def offset_components(self) -> int:
        """Components of the per-word offsets image: first vertex and triangle, and first own vertex."""
        return 4 if self.own_vertices else 2

    @property
    def job_record_bytes(self) -> int:
        return 4 * self.job_components

    @property
    def defines(self) -> dict[str, str]:
        """What its passes are compiled with, from the sizes above (the shared pass bodies, shaders/cells_*.glsl,
        declare the counts image and the job buffer by these): the counts image's format and a job's type."""
        defines = {"WORD_COUNTS_FORMAT": _UINT_IMAGE_FORMATS[self.count_components],
                   "WORD_OFFSETS_FORMAT": _UINT_IMAGE_FORMATS[self.offset_components],
                   "VERTEX_JOB": _UINT_TYPES[self.job_components]}
        if self.own_vertices:
            defines.update(OWN_VERTICES=1, OWN_EDGES=f"{OWN_EDGES}u")
        return defines

    def passes(self) -> dict[str, str]:
        """Every pass's shader, by role."""
        passes = {**SHARED_PASSES, "classify": self.classify, "brick_sums": self.brick_sums,
                  "word_offsets": self.word_offsets, "triangles": self.triangles, "vertices": self.vertices}
        return {**passes, "own_vertices": self.own_vertices} if self.own_vertices else passes

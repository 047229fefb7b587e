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

    @property
    def job_record_bytes(self) -> int:
        return 4 * self.job_components

    @property
    def defines(self) -> dict[str, str]:
        """What its passes are compiled with, from the sizes above (the shared pass bodies, shaders/cells_*.glsl,
        declare the counts image and the job buffer by these): the counts image's format and a job's type."""
        return {"WORD_COUNTS_FORMAT": _UINT_IMAGE_FORMATS[self.count_components],
                "VERTEX_JOB": _UINT_TYPES[self.job_components]}

    def passes(self) -> dict[str, str]:
        """Every pass's shader, by role."""
        return {**SHARED_PASSES, "classify": self.classify, "brick_sums": self.brick_sums,
                "word_offsets": self.word_offsets, "triangles": self.triangles, "vertices": self.vertices}

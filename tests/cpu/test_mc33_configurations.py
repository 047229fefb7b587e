"""MC33's 33 configurations of one cell (Chernyaev 1995), each a 2x2x2 grid written here by hand, meshed with
``topology="trilinear"``: in every rotation, mirror image and inside/outside swap, the mesh has the pieces and
Euler characteristic of the configuration, and the oracle (the trilinear interpolant refined, meshed by
scikit-image) agrees.

The grids are small integers: corner ``c`` of the cell sits at ``(c & 1, c >> 1 & 1, c >> 2 & 1)`` (the case
table's corner order), level 0.  Each configuration is its case (Lorensen's fifteen, up to rotation and
inside/outside) with each ambiguous face's decision (the bilinear saddle above or below the level: the
asymptotic decider) and, where the faces leave it open, the interior's: two disks or one tube.  A disk has
Euler characteristic 1, a tube 0.  No face's saddle sits exactly at the level (a tie, where the interpolant's
level set crosses itself and no topology is the right one).  Configurations with a tube were the ones
published MC33 tables got wrong (Custodio et al. 2013, Vega et al. 2019): scikit-image's Lewiner, for one,
gives 6.1.2, 7.4.2, 12.1.2 and 13.5.2 the wrong topology in all 96 turns here, 10.1.2 in 48 and 4.1.1 in 16.
"""
from __future__ import annotations

import numpy as np
import pytest
from support.mc33 import CASES, MC33, configuration_class, corner_values, face_decisions, grid, symmetries
from support.topology import counts, oracle

import isoscope
from isoscope.cpu.cubes import marching_cubes_reference
from isoscope.cpu.trilinear import marching_cubes_trilinear


def test_the_grids_are_the_33_configurations():
    """Each grid is its name's case, the 33 are distinct configurations, and the oracle, refined 16/32 and
    48/96 times per cell edge, finds each configuration's pieces and Euler characteristic."""
    assert len(MC33) == 33
    seen = set()
    for name, (values, expected) in MC33.items():
        field = grid(values)
        inside = sum(v >= 0 for v in values)
        ambiguous = sum(d >= 0 for d in face_decisions(values))
        assert (min(inside, 8 - inside), ambiguous) == CASES[name.split(".")[0]], name
        seen.add((configuration_class(field), expected))
        for refinements in ((16, 32), (48, 96)):
            assert oracle(field, 0.0, refinements) == expected, name
    assert len(seen) == 33
    # Mirror images are not rotations: 12.2 and 12.3 share their faces' decisions only mirrored.
    assert configuration_class(grid(MC33["12.2"][0])) != configuration_class(grid(MC33["12.3"][0]))
    assert configuration_class(grid(MC33["12.2"][0])) == configuration_class(grid(MC33["12.3"][0])[::-1].copy())


def assert_a_manifold_patch(verts: np.ndarray, faces: np.ndarray) -> None:
    """Inside the cell every edge is in exactly two triangles, opposed; the rest lie in one cube face, once;
    no triangle has zero area."""
    directed = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    assert len({tuple(e) for e in directed.tolist()}) == len(directed)
    reverse = {tuple(e) for e in directed[:, ::-1].tolist()}
    for a, b in directed.tolist():
        if (a, b) not in reverse:
            on_a_face = [(verts[a][axis] == verts[b][axis]) and verts[a][axis] in (0.0, 1.0) for axis in range(3)]
            assert any(on_a_face), "an open edge inside the cell"
    p = verts[faces].astype(np.float64)
    assert (np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1) > 1e-12).all()


@pytest.mark.parametrize("name", list(MC33))
def test_every_turn_of_each_configuration_is_meshed_as_the_interpolant(name):
    """All 96 symmetries of the cell: the numpy specification and the compiled extractor (bit for bit the same)
    give the configuration's pieces and Euler characteristic, as a patch that is manifold inside the cell.  Today's
    mesh (Montani's rule, no tubes) is checked against the same numbers, to show the test tells them apart."""
    values, expected = MC33[name]
    montani_misses = 0
    for field in symmetries(grid(values)):
        reference = marching_cubes_trilinear(field, 0.0)
        assert counts(*reference[:2]) == expected, (name, corner_values(field))
        if expected != (0, 0):
            compiled, numpy = (isoscope.api.outward_marching_cubes(field, 0.0, backend=backend, topology="trilinear")
                               for backend in ("cpu", "numpy"))
            for a, b in zip(compiled, numpy):
                np.testing.assert_array_equal(a, b)
            assert_a_manifold_patch(reference[0], reference[1])
        montani_misses += counts(*marching_cubes_reference(field, 0.0)[:2]) != expected
    if expected[0] > expected[1]:      # a tube (Euler characteristic 0): today's mesh has none
        assert montani_misses == 96, name


def test_todays_mesh_misses_most_configurations():
    """Montani's rule decides every ambiguous face one way: it gives the wrong topology on some turn of 21 of the
    33 configurations (every turn of those with a tube)."""
    missed = [name for name, (values, expected) in MC33.items()
              if any(counts(*marching_cubes_reference(field, 0.0)[:2]) != expected
                     for field in symmetries(grid(values)))]
    assert len(missed) >= 20

"""topology="trilinear" in numpy (the specification): its meshes against an oracle of the trilinear
interpolant on random grids, closed and 2-manifold where the field is, and today's mesh where nothing is
ambiguous."""
from __future__ import annotations

import numpy as np
import pytest
from support.topology import configuration, counts, oracle, single_cells
from support.trilinear_cases import bit_for_bit_cases, closed_noise

from isoscope.cpu.cubes import marching_cubes_reference
from isoscope.cpu.trilinear import marching_cubes_trilinear, trilinear_keys


def random_grids(seed: int, shape, count: int):
    rng = np.random.default_rng(seed)
    return [rng.standard_normal(shape).astype(np.float32) for _ in range(count)]


@pytest.mark.parametrize("shape, seed", [((2, 2, 2), 1), ((3, 3, 3), 2), ((3, 3, 3), 3), ((4, 3, 3), 4),
                                         ((3, 3, 3), 5), ((3, 3, 3), 6), ((3, 4, 3), 7), ((3, 3, 3), 8)])
def test_pieces_and_euler_characteristic_are_the_interpolants(shape, seed):
    """Every random grid where the oracle is sure (1,000 grids in all, 125 a seed): the same pieces and Euler
    characteristic.  Today's mesh (Montani's faces, no tunnels) misses on most of the same grids: the test
    tells the two apart."""
    sure = agree = today = 0
    for field in random_grids(seed, shape, 125):
        truth = oracle(field)
        if truth is None:
            continue
        sure += 1
        got = counts(*marching_cubes_trilinear(field, 0.0)[:2])
        if got != truth:   # a feature thinner than a twelfth of a cell hides from the quick oracle: look closer
            truth = oracle(field, refinements=(24, 48))
        assert got == truth, field.tolist()
        agree += 1
        today += counts(*marching_cubes_reference(field, 0.0)[:2]) == truth
    assert sure >= 110
    if shape != (2, 2, 2):
        assert today < 0.7 * agree


def tunnel_cell(joined: bool):
    """Case 4: corners 0 and 7 inside, the rest out; the interior joins them when the others are shallow."""
    field = np.full((2, 2, 2), -0.25 if joined else -1.0, dtype=np.float32)
    field[0, 0, 0] = field[1, 1, 1] = 1.0
    return field


@pytest.mark.parametrize("joined", [False, True])
def test_a_tunnel_through_one_cell(joined):
    assert oracle(tunnel_cell(joined)) == ((1, 0) if joined else (2, 2))
    verts, faces, _, _ = marching_cubes_trilinear(tunnel_cell(joined), 0.0)
    assert counts(verts, faces) == ((1, 0) if joined else (2, 2))
    tunnel = (trilinear_keys(tunnel_cell(joined), np.float32(0), tunnel_cell(joined) >= 0) >> 14).item()
    assert (tunnel == 1) == joined   # key 1: the section at the saddle's extremum joins corners 0 and 7


def edges_of(faces):
    return np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_closed_noise_gives_a_closed_oriented_two_manifold(seed):
    verts, faces, normals, values = marching_cubes_trilinear(closed_noise(seed), 0.0)
    directed = edges_of(faces)
    assert len(np.unique(directed, axis=0)) == len(directed)          # no directed edge twice
    flipped = {tuple(e) for e in directed[:, ::-1]}
    assert all(tuple(e) in flipped for e in directed)                    # each edge in exactly two, opposed
    # Each vertex's triangles form one fan (no two cones pinched at a vertex): its ring is one cycle.
    order = np.argsort(faces.ravel(), kind="stable")
    for vertex in np.unique(faces)[::7]:
        tris = faces[np.nonzero((faces == vertex).any(axis=1))[0]]
        ring = {}
        for t in tris:
            k = list(t).index(vertex)
            ring[t[(k + 1) % 3]] = t[(k + 2) % 3]
        start, at, steps = next(iter(ring)), None, 0
        at = ring[start]
        while at != start:
            at, steps = ring[at], steps + 1
        assert steps + 1 == len(ring)
    del order
    # No zero-area triangle; normals unit; the cells' own vertices inside the volume.
    p = verts[faces]
    assert (np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1) > 0).all()
    assert np.allclose(np.linalg.norm(normals, axis=1), 1, atol=1e-5)
    assert np.isfinite(values).all()


def test_vertices_on_todays_edges_and_todays_mesh_where_nothing_is_ambiguous():
    x, y, z = np.mgrid[-1:1:30j, -1:1:30j, -1:1:30j]
    ball = (0.7 - np.sqrt(x * x + y * y + z * z)).astype(np.float32)
    today, ours = marching_cubes_reference(ball, 0.0), marching_cubes_trilinear(ball, 0.0)
    for a, b in zip(today, ours):
        np.testing.assert_array_equal(a, b)
    noise = closed_noise(5)
    today, ours = marching_cubes_reference(noise, 0.0), marching_cubes_trilinear(noise, 0.0)
    n = len(today[0])
    np.testing.assert_array_equal(ours[0][:n], today[0])   # every crossing edge's vertex, in today's order
    assert len(ours[0]) >= n and not np.array_equal(ours[1], today[1])


@pytest.mark.parametrize("name, volume, level, direction", bit_for_bit_cases(11), ids=lambda v: v if isinstance(v, str)
                         else None)
def test_the_compiled_extractor_gives_the_references_mesh_bit_for_bit(name, volume, level, direction):
    import isoscope
    spacing = (0.5, 1.0, 2.0)
    ours = isoscope.api.outward_marching_cubes(volume, level, spacing=spacing, gradient_direction=direction,
                                               backend="cpu", topology="trilinear")
    reference = marching_cubes_trilinear(np.asarray(volume, np.float32), level, spacing,
                                         descent=direction == "descent")
    for a, b in zip(ours, reference):
        np.testing.assert_array_equal(a, b)
    assert len(ours[0]) > 100


def test_every_door_takes_the_topology_and_refuses_what_it_cannot_do():
    import isoscope
    from isoscope.errors import IsoscopeError
    cell = tunnel_cell(joined=True)
    for backend in ("cpu", "numpy", "auto"):
        _, faces, _, values = isoscope.marching_cubes(cell, 0.0, backend=backend, topology="trilinear")
        assert len(faces) == 6 and np.isfinite(values).all()
    field = closed_noise(3, 12)
    one_shot = isoscope.api.outward_marching_cubes(field, 0.0, backend="cpu", topology="trilinear")
    with isoscope.Extractor(field, backend="cpu", topology="trilinear") as extractor:
        extractor.extract(0.5)
        extractor.extract(0.0)
        resident = extractor.read_mesh()
    for a, b in zip(one_shot, resident):
        np.testing.assert_array_equal(a, b)
    mesh = isoscope.isosurface(field, 0.0, topology="trilinear")
    assert len(mesh.faces) == len(one_shot[1])
    refusals = [dict(topology="mc33"), dict(topology="trilinear", sharp_features=30),
                dict(topology="trilinear", mask=np.ones(field.shape, bool))]
    for options in refusals:
        with pytest.raises(IsoscopeError) as caught:
            isoscope.marching_cubes(field, 0.0, **options)
        assert "\n" not in str(caught.value)
    with pytest.raises(IsoscopeError):
        isoscope.Extractor(field, backend="cpu", topology="mc33")


def test_every_configuration_of_one_cell_is_the_interpolants():
    """Cells of every configuration random cells reach (25 families: disks of 3 to 12 vertices, one to four of
    them, tubes between a triangle and a triangle, quad, pentagon or hexagon, fans from the cell's own vertex),
    up to three keys each: pieces and Euler characteristic as the oracle's (bench_topology.py sweeps every
    key random cells reach, 1,212 of them)."""
    by_configuration: dict[tuple, list[int]] = {}
    cells = single_cells()
    for key in cells:
        by_configuration.setdefault(configuration(key), []).append(key)
    assert len(by_configuration) >= 20 and sum(tube for _, tube, _ in by_configuration) >= 5
    checked = 0
    for keys in by_configuration.values():
        for key in keys[:3]:
            field = cells[key]
            truth = oracle(field, refinements=(8, 16))
            got = counts(*marching_cubes_trilinear(field, 0.0)[:2])
            if truth is not None and got != truth:
                truth = oracle(field, refinements=(24, 48))
            if truth is not None:
                assert got == truth, (key, configuration(key), field.tolist())
                checked += 1
    assert checked >= 55

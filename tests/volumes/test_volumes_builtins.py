"""The generated volumes: each opens, has a surface at its level, and declares its inside correctly."""
from __future__ import annotations

import itertools

import numpy as np
import pytest

from isoscope.volumes import DEFAULT_VOLUME, VolumeError, builtin_names, describe_builtins, open_volume
from isoscope.volumes.builtins import AMBIGUOUS_SHAPE, c60_atoms

DOCUMENTED_BUILTINS = {"sphere", "torus", "plane", "gyroid", "metaballs", "bucky", "box", "ambiguous"}


def test_every_documented_builtin_is_listed_with_a_description():
    assert DOCUMENTED_BUILTINS <= set(builtin_names())
    described = dict(describe_builtins())
    assert set(described) == set(builtin_names())
    assert all(text and "\n" not in text for text in described.values())


@pytest.mark.parametrize("name", sorted(DOCUMENTED_BUILTINS))
def test_builtin_has_a_surface_at_its_default_level(name):
    volume = open_volume(name if name == "ambiguous" else f"{name}:24")
    data = volume.data
    assert data.ndim == 3 and data.flags.c_contiguous
    assert volume.gradient_direction in ("ascent", "descent")
    lo, hi = float(data.min()), float(data.max())
    assert lo < volume.default_level < hi, "the first frame would show nothing"
    assert np.isfinite(data.astype(np.float64)).all()


def _centre(volume):
    return volume.data[tuple(n // 2 for n in volume.data.shape)]


@pytest.mark.parametrize("name", ["sphere", "torus", "box", "metaballs"])
def test_inside_is_on_the_declared_side(name):
    """Corners of the box are outside every closed object; the object side is the other one."""
    volume = open_volume(f"{name}:33")
    corner = float(volume.data[0, 0, 0])
    level = volume.default_level
    if volume.gradient_direction == "ascent":
        assert corner > level
    else:
        assert corner < level
    if name != "torus":  # the torus has a hole in the middle
        centre = float(_centre(volume))
        assert (centre < level) if volume.gradient_direction == "ascent" else (centre > level)


def test_torus_hole_is_outside_and_its_tube_is_inside():
    volume = open_volume("torus:41")  # samples at multiples of 0.05: x = 0.6 is sample 32
    assert volume.data[20, 20, 20] > 0
    assert volume.data[32, 20, 20] < 0


def test_plane_is_x_plus_2y_minus_3z_plus_1_with_axis_0_as_x():
    volume = open_volume("plane:9")
    axis = np.linspace(-1.0, 1.0, 9)
    x, y, z = np.meshgrid(axis, axis, axis, indexing="ij")
    np.testing.assert_allclose(volume.data, x + 2 * y - 3 * z + 1, atol=1e-6)
    assert volume.spacing == pytest.approx((0.25, 0.25, 0.25))


def test_resolution_from_the_spec_or_the_flag_and_a_conflict_is_refused():
    assert open_volume("sphere:20").data.shape == (20, 20, 20)
    assert open_volume("sphere", resolution=18).data.shape == (18, 18, 18)
    assert open_volume("sphere:18", resolution=18).data.shape == (18, 18, 18)
    with pytest.raises(VolumeError, match="resolution given twice"):
        open_volume("sphere:20", resolution=30)
    with pytest.raises(VolumeError, match="out of range"):
        open_volume("sphere:1")
    with pytest.raises(VolumeError, match="not a whole number"):
        open_volume("sphere:big")


def test_c60_atoms_form_a_truncated_icosahedron():
    atoms = c60_atoms()
    assert len(np.unique(atoms.round(6), axis=0)) == 60
    radii = np.linalg.norm(atoms, axis=1)
    np.testing.assert_allclose(radii, radii[0])
    distances = np.linalg.norm(atoms[:, None] - atoms[None], axis=-1)
    np.fill_diagonal(distances, np.inf)
    nearest = distances.min(axis=1)
    np.testing.assert_allclose(nearest, nearest[0])
    # Each carbon has 3 bonds: 2 in pentagons, 1 between hexagons; all edges equal here.
    assert (np.isclose(distances, nearest[0]).sum(axis=1) == 3).all()


def test_bucky_is_uint8_like_the_cuda_sample_and_dense_at_the_atoms():
    volume = open_volume("bucky:48")
    assert volume.data.dtype == np.uint8 and volume.gradient_direction == "descent"
    assert _centre(volume) < volume.default_level  # a hollow cage


def test_ambiguous_field_contains_every_marching_cubes_case():
    volume = open_volume("ambiguous")
    inside = volume.data > volume.default_level
    assert volume.data.shape == AMBIGUOUS_SHAPE
    cases = np.zeros(tuple(n - 1 for n in inside.shape), dtype=np.int32)
    for bit, (dx, dy, dz) in enumerate(itertools.product((0, 1), repeat=3)):
        corner = inside[dx:dx + cases.shape[0], dy:dy + cases.shape[1], dz:dz + cases.shape[2]]
        cases |= corner.astype(np.int32) << bit
    assert set(np.unique(cases)) == set(range(256))
    assert not np.any(volume.data == volume.default_level), "exact ties would hide the ambiguity"


def test_default_volume_opens():
    volume = open_volume(DEFAULT_VOLUME)
    assert 64 <= max(volume.data.shape) <= 96


@pytest.mark.parametrize("name", ["sphere", "torus", "box", "metaballs", "bucky"])
def test_closed_objects_stay_inside_the_box(name):
    """Every face of the grid is on the outside, so the surface is closed, not cut by the box."""
    volume = open_volume(name)
    data = volume.data.astype(np.float64)
    faces = np.concatenate([data[0].ravel(), data[-1].ravel(), data[:, 0].ravel(),
                            data[:, -1].ravel(), data[:, :, 0].ravel(), data[:, :, -1].ravel()])
    if volume.gradient_direction == "ascent":
        assert faces.min() > volume.default_level
    else:
        assert faces.max() < volume.default_level

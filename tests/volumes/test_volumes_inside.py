"""--inside says which side of the level the object is on, so normals point out of it."""

import numpy as np
import pytest
from support.command import isoscope_here
from support.mesh_checks import read_ply

from isoscope.api import outward_marching_cubes
from isoscope.volumes import VolumeError, open_volume


@pytest.fixture
def sdf_file(tmp_path):
    """A sphere's signed distance (negative inside) saved as .npy: files default to 'above'."""
    axis = np.linspace(-1, 1, 24, dtype=np.float32)
    x, y, z = np.meshgrid(axis, axis, axis, indexing="ij")
    path = tmp_path / "ball_sdf.npy"
    np.save(path, np.sqrt(x * x + y * y + z * z) - 0.6)
    return path


def outward_fraction(volume):
    verts, _, normals, _ = outward_marching_cubes(volume.data, 0.0, gradient_direction=volume.gradient_direction,
                                                  backend="cpu")
    radial = verts - verts.mean(axis=0)
    return float((np.einsum("ij,ij->i", normals, radial) > 0).mean())


def test_files_are_densities_by_default_and_inside_below_flips_the_normals(sdf_file):
    as_density = open_volume(str(sdf_file))
    assert as_density.gradient_direction == "descent"
    assert outward_fraction(as_density) == 0.0       # an SDF read as a density: normals point in
    as_sdf = open_volume(str(sdf_file), inside="below")
    assert as_sdf.gradient_direction == "ascent"
    assert outward_fraction(as_sdf) == 1.0


def test_inside_overrides_a_builtin_too():
    assert open_volume("sphere:16").gradient_direction == "ascent"
    assert open_volume("sphere:16", inside="above").gradient_direction == "descent"


def test_bad_inside_value_is_a_one_line_error(sdf_file):
    with pytest.raises(VolumeError, match="above.*below"):
        open_volume(str(sdf_file), inside="left")


def export(sdf_file, out, *flags):
    return isoscope_here("export", sdf_file, "--iso", "0", "--out", out, *flags)


def test_cli_flag_reaches_the_exported_mesh(sdf_file, tmp_path):

    as_density, as_sdf = tmp_path / "density.ply", tmp_path / "sdf.ply"
    for out, flags in ((as_density, ()), (as_sdf, ("--inside", "below"))):
        done = export(sdf_file, out, *flags)
        assert done.returncode == 0, done.stderr
    density_verts, density_normals, _, _ = read_ply(as_density)
    sdf_verts, sdf_normals, _, _ = read_ply(as_sdf)
    # Same surface, normals reversed (each side's normals point out of its object).
    np.testing.assert_allclose(sdf_verts, density_verts, atol=1e-6)
    np.testing.assert_allclose(sdf_normals, -density_normals, atol=1e-5)

    done = export(sdf_file, tmp_path / "x.ply", "--inside", "sideways")
    assert done.returncode == 2 and "--inside" in done.stderr

"""Smoothing projected onto the level set (issue 9): facts checked with scipy's own trilinear
interpolation, triangle angles and areas, and the GPU against the numpy reference."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.ndimage import gaussian_filter, map_coordinates
from support.command import assert_one_line_error
from support.command import isoscope_here as run_cli
from support.mesh_checks import signed_volume, triangle_areas

import isoscope
from isoscope.api import outward_marching_cubes
from isoscope.cpu.smooth import smooth_projected
from isoscope.gpu.cubes import Extractor
from isoscope.gpu.smooth import Smoother
from isoscope.volumes import open_volume

SPACING = (1.0, 1.5, 0.75)


def smooth_noise(shape=(40, 44, 50), seed=7):
    field = gaussian_filter(np.random.default_rng(seed).standard_normal(shape).astype(np.float32), 3)
    return field - field.mean()


def trilinear_off_level(volume, verts, level, spacing):
    """|F(v) - level| / value range, F the trilinear interpolant (scipy, float64)."""
    index = (verts / np.asarray(spacing, np.float64)).T
    values = map_coordinates(np.asarray(volume, np.float64), index, order=1, mode="nearest")
    return np.abs(values - level) / (float(volume.max()) - float(volume.min()))


def smallest_angles(verts, faces):
    """Each triangle's smallest angle, degrees."""
    corners = verts[faces].astype(np.float64)
    angles = []
    for i in range(3):
        a, b = corners[:, (i + 1) % 3] - corners[:, i], corners[:, (i + 2) % 3] - corners[:, i]
        cos = np.sum(a * b, axis=1) / (np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1))
        angles.append(np.degrees(np.arccos(np.clip(cos, -1, 1))))
    return np.min(angles, axis=0)


def histogram(angles):
    counts, _ = np.histogram(angles, bins=[0, 5, 10, 20, 30, 40, 50, 60.1])
    return " ".join(f"{c / len(angles):6.1%}" for c in counts) + "   (0-5-10-20-30-40-50-60 deg)"


@pytest.mark.parametrize("backend", ["gpu", "cpu"])
@pytest.mark.parametrize("direction", ["descent", "ascent"])
def test_every_vertex_stays_on_the_trilinear_level_set(backend, direction):
    volume, level = smooth_noise(), 0.02
    plain = outward_marching_cubes(volume, level, spacing=SPACING, gradient_direction=direction, backend=backend)
    for iterations in (1, 2, 5, 12):  # isoscope's own mesh: its values are the interpolant's, on the level
        verts, faces, normals, values = outward_marching_cubes(
            volume, level, spacing=SPACING, gradient_direction=direction, backend=backend, smooth=iterations)
        assert trilinear_off_level(volume, verts, level, SPACING).max() <= 1e-3
        np.testing.assert_array_equal(faces, plain[1])
        assert np.abs(verts - plain[0]).max() > 0.1  # it did move them
        np.testing.assert_allclose(values, level, atol=1e-3 * float(np.ptp(volume)))


def test_normals_follow_the_field_gradient_at_the_new_positions():
    volume, level = smooth_noise(), 0.0
    verts, faces, normals, _ = isoscope.marching_cubes(volume, level, spacing=SPACING, smooth=3)
    gradients = np.gradient(volume.astype(np.float64), *SPACING)  # central differences, one-sided at the border
    index = (verts / np.asarray(SPACING)).T
    expected = -np.stack([map_coordinates(g, index, order=1) for g in gradients], axis=1)
    expected /= np.linalg.norm(expected, axis=1, keepdims=True)
    assert np.sum(normals * expected, axis=1).min() > 0.9999


def test_vertices_on_the_border_stay_on_it():
    volume = smooth_noise()
    verts, faces, _, _ = isoscope.marching_cubes(volume, 0.0)
    smoothed = isoscope.marching_cubes(volume, 0.0, smooth=5)[0]
    top = np.array(volume.shape) - 1
    for axis in range(3):
        for end in (0, top[axis]):
            on = np.abs(verts[:, axis] - end) < 1e-6
            assert on.sum() > 20
            np.testing.assert_allclose(smoothed[on, axis], end, atol=1e-4)


def density_volume():
    bucky = open_volume("bucky")  # C60's atoms as Gaussian blobs, uint8 (the integer texture path)
    return bucky.data, 128.0, bucky.spacing, "descent"


def noise_volume():
    return smooth_noise((64, 64, 64), seed=3), 0.0, (1.0, 1.0, 1.0), "descent"


@pytest.mark.parametrize("make", [noise_volume, density_volume])
def test_slivers_drop_five_fold_in_five_iterations(make):
    volume, level, spacing, direction = make()
    before = isoscope.marching_cubes(volume, level, spacing=spacing, gradient_direction=direction)
    after = isoscope.marching_cubes(volume, level, spacing=spacing, gradient_direction=direction, smooth=5)
    angles_before, angles_after = smallest_angles(*before[:2]), smallest_angles(*after[:2])
    print(f"\n{make.__name__} smallest angle, before: {histogram(angles_before)}"
          f"\n{make.__name__} smallest angle, after:  {histogram(angles_after)}")
    slivers_before, slivers_after = (angles_before < 10).mean(), (angles_after < 10).mean()
    assert slivers_before > 0.02
    assert slivers_after * 5 <= slivers_before
    assert trilinear_off_level(volume, after[0], level, spacing).max() <= 1e-3


@pytest.mark.parametrize("backend", ["gpu", "cpu"])
@pytest.mark.parametrize("size, radius", [(32, 0.7), (48, 0.5), (64, 0.6), (80, 0.37), (100, 0.8)])
def test_sphere_area_error_is_no_worse_than_unsmoothed(size, radius, backend):
    """Against 4 pi r^2 itself, at 11-40 cells of radius: plain marching cubes' vertices sit on grid
    edges, where the trilinear interpolant misses the sphere least; smoothed ones move into cells, where
    it lies furthest inside (without the level's correction for that, the area came out ~1.5x further
    below 4 pi r^2 than plain's).  Enclosed volume changes by under 0.5%."""
    axis = np.linspace(-1, 1, size, dtype=np.float32)
    x, y, z = np.meshgrid(axis, axis, axis, indexing="ij")
    field = (np.sqrt(x * x + y * y + z * z) - radius).astype(np.float32)
    spacing = (2.0 / (size - 1),) * 3
    plain = isoscope.marching_cubes(field, 0.0, spacing=spacing, gradient_direction="ascent", backend=backend)
    smoothed = isoscope.marching_cubes(field, 0.0, spacing=spacing, gradient_direction="ascent", backend=backend,
                                       smooth=5)
    area = 4 * np.pi * radius ** 2
    plain_error = abs(triangle_areas(*plain[:2]).sum() - area) / area
    smoothed_error = abs(triangle_areas(*smoothed[:2]).sum() - area) / area
    print(f"\nsphere r = {radius / spacing[0]:.1f} cells: area error plain {plain_error:.4%}, "
          f"smoothed {smoothed_error:.4%}")
    assert smoothed_error <= plain_error
    assert abs(signed_volume(*smoothed[:2]) / signed_volume(*plain[:2]) - 1) < 0.005
    assert trilinear_off_level(field, smoothed[0], 0.0, spacing).max() <= 1e-3


@pytest.mark.parametrize("direction", ["descent", "ascent"])
def test_gpu_matches_the_numpy_reference(gl_ctx, direction):
    volume, level = smooth_noise(), 0.01
    with Extractor(volume, spacing=SPACING, gradient_direction=direction, ctx=gl_ctx) as ex:
        ex.extract(level)
        verts, faces, normals, _ = ex.read_mesh()
        smoother = Smoother(ex)
        for iterations in (1, 5):
            ex.extract(level)
            smoother.smooth(ex.mesh, iterations)
            gpu = ex.read_mesh()
            cpu = smooth_projected(verts, faces, volume, level, iterations, SPACING,
                                   descent=direction == "descent", normals=normals)
            np.testing.assert_array_equal(gpu[1], cpu[1])
            apart = np.abs(gpu[0] - cpu[0]).max(axis=1)
            # Float rounding (mix() vs a + t(b - a), sums in another order) grows a little per
            # iteration; a few vertices where Newton's steps are badly conditioned drift further.
            assert np.mean(apart < 1e-4) > 0.999
            assert apart.max() < 2e-3
            assert np.mean(np.abs(gpu[2] - cpu[2]).max(axis=1) < 1e-3) > 0.999
            np.testing.assert_allclose(gpu[3], cpu[3], atol=1e-6)
        smoother.release()


@pytest.mark.parametrize("shape", [(2, 9, 7), (3, 5, 40), (4, 4, 4), (3, 3, 3), (33, 3, 12)])
def test_gpu_matches_the_numpy_reference_on_thin_grids(gl_ctx, shape):
    # Axes of 2, 3 and 4 samples take every border branch of the level's curvature correction.
    volume = gaussian_filter(np.random.default_rng(1).standard_normal(shape).astype(np.float32), 1.0)
    volume -= volume.mean()
    with Extractor(volume, spacing=SPACING, ctx=gl_ctx) as ex:
        ex.extract(0.0)
        verts, faces, normals, _ = ex.read_mesh()
        assert len(faces) > 0
        smoother = Smoother(ex)
        ex.extract(0.0)
        smoother.smooth(ex.mesh, 5)
        gpu = ex.read_mesh()
        smoother.release()
    cpu = smooth_projected(verts, faces, volume, 0.0, 5, SPACING, normals=normals)
    assert np.abs(gpu[0] - verts).max() > 0.1
    np.testing.assert_allclose(gpu[0], cpu[0], atol=1e-4)


def test_an_empty_mesh_and_zero_iterations_change_nothing(gl_ctx):
    volume = smooth_noise((12, 12, 12))
    with Extractor(volume, ctx=gl_ctx) as ex:
        smoother = Smoother(ex)
        with pytest.raises(ValueError, match="extract one first"):
            smoother.smooth(ex.mesh, 1, None)
        assert ex.extract(float(volume.min())) == (0, 0)  # every sample is inside: no surface
        smoother.smooth(ex.mesh, 3)
        ex.extract(0.0)
        before = ex.read_mesh()
        smoother.smooth(ex.mesh, 0)
        for a, b in zip(before, ex.read_mesh()):
            assert a.tobytes() == b.tobytes()
        smoother.release()


@pytest.mark.gl
def test_smooth_mesh_smooths_another_extractors_mesh():
    from skimage.measure import marching_cubes as skimage_mc
    volume = smooth_noise()
    verts, faces, _, _ = skimage_mc(volume, 0.0, spacing=SPACING)
    for backend in ("gpu", "cpu"):
        smoothed, same_faces, _, _ = isoscope.smooth_mesh(volume, verts, faces, 0.0, 5, spacing=SPACING,
                                                          backend=backend)
        assert same_faces.tolist() == faces.tolist()
        assert trilinear_off_level(volume, smoothed, 0.0, SPACING).max() <= 1e-3
        assert (smallest_angles(smoothed, faces) < 10).mean() * 5 <= (smallest_angles(verts, faces) < 10).mean()


@pytest.mark.parametrize("bad", [-1, 2.5, "5", True, None])
def test_bad_iteration_counts_are_one_line_errors(bad):
    volume = smooth_noise((8, 8, 8))
    with pytest.raises(ValueError, match="whole number of iterations") as error:
        isoscope.marching_cubes(volume, 0.0, smooth=bad, backend="cpu")
    assert "\n" not in str(error.value)


@pytest.mark.gl
def test_cli_smooth(tmp_path):
    from support.mesh_checks import read_ply
    assert_one_line_error(run_cli("export", "torus", "--out", tmp_path / "t.ply", "--smooth", "-2"), "--smooth")
    assert_one_line_error(run_cli("render", "torus", "--out", tmp_path / "t.png", "--smooth", "x"), "--smooth")
    for n in (0, 4):
        result = run_cli("export", "torus", "--resolution", 24, "--space", "voxel", "--out", tmp_path / f"{n}.ply",
                         "--smooth", n)
        assert result.returncode == 0, result.stderr
    plain, smoothed = read_ply(tmp_path / "0.ply"), read_ply(tmp_path / "4.ply")
    slivers = [(smallest_angles(verts, faces) < 10).mean() for verts, _, _, faces in (plain, smoothed)]
    assert slivers[1] * 5 <= slivers[0]
    result = run_cli("render", "torus", "--resolution", 24, "--out", tmp_path / "t.png", "--smooth", 3)
    assert result.returncode == 0 and (tmp_path / "t.png").stat().st_size > 1000, result.stderr


def test_viewer_state_re_extracts_when_smoothing_changes(gl_ctx):
    from isoscope.viewer.gfx.scene import GpuScene
    from isoscope.viewer.model.state import ViewerState
    state = ViewerState()
    scene = GpuScene(gl_ctx, state)
    scene.show(open_volume("torus", resolution=24))
    plain = smallest_angles(*scene.extractor.read_mesh()[:2])
    assert state.set_smooth(4)
    assert scene.update(0.0)
    smoothed = smallest_angles(*scene.extractor.read_mesh()[:2])
    assert (smoothed < 10).mean() * 5 <= (plain < 10).mean()
    assert not scene.update(0.0)
    scene.release()


@pytest.mark.parametrize("backend", ["gpu", "cpu"])
def test_tetrahedra_meshes_are_smoothed_onto_the_level_set_too(backend):
    # Smoothing works on any indexed mesh of the volume: the tetrahedra's, ~3x the triangles, more slivers.
    volume, level = smooth_noise((30, 32, 34)), 0.02
    plain = isoscope.marching_tetrahedra(volume, level, spacing=SPACING, backend=backend)
    verts, faces, _, _ = isoscope.marching_tetrahedra(volume, level, spacing=SPACING, backend=backend, smooth=5)
    np.testing.assert_array_equal(faces, plain[1])
    assert trilinear_off_level(volume, verts, level, SPACING).max() <= 1e-3
    assert (smallest_angles(verts, faces) < 10).mean() < (smallest_angles(*plain[:2]) < 10).mean() / 5

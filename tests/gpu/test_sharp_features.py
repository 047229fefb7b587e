"""Extended Marching Cubes (sharp features) against the true geometry of boxes built here in numpy."""
from __future__ import annotations

import moderngl
import numpy as np
import pytest
from support.command import assert_one_line_error, isoscope_here
from support.mesh_checks import assert_closed_manifold, edge_use_counts, signed_volume, triangle_areas
from support.sdf_boxes import Box, distance_to_mesh, grid_points, rotation

from isoscope.api import outward_marching_cubes
from isoscope.core.sharp.eno import edge_of_vertex
from isoscope.core.sharp.features import check_feature_angle, sharpen_extracted
from isoscope.core.sharp.normals import crisp_normals

N = 24  # samples per axis: boxes about 10 cells wide
SCENES = {
    "box": [Box([11.3, 12.4, 11.6], [6.2, 4.7, 5.4])],
    "rotated box": [Box([11.7, 12.2, 11.9], [6.3, 4.8, 5.5], rotation(0.3, 0.5, 0.7))],
    "union of two boxes": [Box([9.4, 11.3, 11.6], [5.2, 4.1, 4.4], rotation(0.2, -0.3, 0.4)),
                           Box([14.6, 12.4, 12.1], [4.6, 5.3, 3.7], rotation(-0.5, 0.1, 0.9))],
}


def union_sdf(boxes, points):
    return np.minimum.reduce([b.sdf(points) for b in boxes])


def on_surface(boxes, points):
    """The points that lie on the union's surface (a box's edge inside the other box is no edge)."""
    return points[np.abs(union_sdf(boxes, points)) < 1e-6]


@pytest.fixture(scope="module", params=list(SCENES))
def scene(request):
    boxes = SCENES[request.param]
    volume = union_sdf(boxes, grid_points(N)).astype(np.float32)
    plain = outward_marching_cubes(volume, 0.0, gradient_direction="ascent", backend="cpu")
    sharp = outward_marching_cubes(volume, 0.0, gradient_direction="ascent", backend="cpu", sharp_features=30)
    edges = on_surface(boxes, np.concatenate([b.edge_points() for b in boxes]))
    corners = on_surface(boxes, np.concatenate([b.corners() for b in boxes]))
    return dict(boxes=boxes, volume=volume, plain=plain, sharp=sharp, edges=edges, corners=corners,
                edge_distance={name: distance_to_mesh(edges, m[0], m[1]) for name, m in
                               (("plain", plain), ("sharp", sharp))})


def corner_distances(corners, verts):
    return np.linalg.norm(corners[:, None] - verts[None], axis=-1).min(axis=1)


def test_mesh_stays_closed_two_manifold_and_outward(scene):
    verts, faces, normals, _ = scene["sharp"]
    assert_closed_manifold(faces)
    assert np.array_equal(np.unique(faces), np.arange(len(verts)))  # every vertex in some face
    assert triangle_areas(verts, faces).min() > 1e-9
    assert signed_volume(verts, faces) > 0  # counter-clockwise seen from outside
    assert np.isfinite(verts).all() and np.allclose(np.linalg.norm(normals, axis=1), 1, atol=1e-4)
    # The plain vertices stay, in order, each on its grid edge (one moves along it only where the field
    # bends between the edge's samples: sharp_planes.kink_vertices); the feature vertices come after them.
    plain = scene["plain"][0]
    n_plain = len(plain)
    assert len(verts) > n_plain
    for a, b in zip(edge_of_vertex(verts[:n_plain], np.arange(n_plain), np.ones(3))[:2],
                    edge_of_vertex(plain, np.arange(n_plain), np.ones(3))[:2]):
        np.testing.assert_array_equal(a, b)
    moved = (verts[:n_plain] != plain).any(axis=1)
    assert moved.sum() < 0.2 * n_plain


def test_edges_come_much_closer_than_plain_marching_cubes(scene):
    plain, sharp = scene["edge_distance"]["plain"], scene["edge_distance"]["sharp"]
    print(f"edge distance plain: median {np.median(plain):.3f} p90 {np.percentile(plain, 90):.3f} "
          f"max {plain.max():.3f}; sharp: median {np.median(sharp):.3f} p90 {np.percentile(sharp, 90):.3f} "
          f"max {sharp.max():.3f} (cells)")
    assert np.median(sharp) <= 0.25 * np.median(plain)
    assert np.percentile(sharp, 90) <= 0.65 * np.percentile(plain, 90)
    assert sharp.max() <= plain.max()


def test_corners_come_closer_and_vertices_stay_on_the_surface(scene):
    plain = corner_distances(scene["corners"], scene["plain"][0])
    sharp = corner_distances(scene["corners"], scene["sharp"][0])
    print(f"corner distance plain {np.round(plain, 2)}; sharp {np.round(sharp, 2)}")
    assert sharp.mean() <= 0.5 * plain.mean()
    assert np.median(sharp) <= 0.3
    # Feature vertices lie near the true surface: plain MC's edge vertices are up to ~0.3 cells off, and
    # most feature vertices within that; a patch next to a corner whose planes are blends can be ~0.7 off.
    off = {name: np.abs(union_sdf(scene["boxes"], scene[name][0])) for name in ("plain", "sharp")}
    print(f"largest distance of a vertex off the surface: plain {off['plain'].max():.3f} "
          f"sharp {off['sharp'].max():.3f}")
    assert np.percentile(off["sharp"], 99) <= off["plain"].max() + 0.05
    assert off["sharp"].max() <= 0.7


CORNER_EDGE_BOUND = {"box": 0.05, "rotated box": 0.3}


@pytest.mark.parametrize("name", list(CORNER_EDGE_BOUND))
def test_edges_run_straight_out_of_a_corner_that_neighbouring_cells_share(name):
    # A corner just outside its cell is the point of that cell's patch and of its neighbours' (a corner
    # pokes into them): joined into one fan (reference_sharp._merge_coincident), the edges leave it
    # straight.  Apart, one of two vertices at the corner retreated toward its patch's middle and the
    # edge kinked through it: 0.323 cells off the rotated box's edge next to a corner, 0.095 the box's.
    boxes = SCENES[name]
    volume = union_sdf(boxes, grid_points(N)).astype(np.float32)
    verts, faces = outward_marching_cubes(volume, 0.0, gradient_direction="ascent", backend="cpu",
                                          sharp_features=30)[:2]
    corners = on_surface(boxes, np.concatenate([b.corners() for b in boxes]))
    edges = on_surface(boxes, np.concatenate([b.edge_points() for b in boxes]))
    near = edges[np.linalg.norm(edges[:, None] - corners[None], axis=-1).min(axis=1) < 1.0]
    assert distance_to_mesh(near, verts, faces).max() <= CORNER_EDGE_BOUND[name]
    assert corner_distances(corners, verts).max() <= 0.01
    assert_closed_manifold(faces)


def test_a_union_whose_sample_planes_include_opposite_faces_is_sharpened():
    # Near a thin part of this union a cell sees two parallel, opposite faces among its sample planes: they
    # meet in no line (sharp_planes._surface_pair divided by 1 - cos^2 = 0, and the step stopped with an
    # IndexError on the NaN point).
    boxes = [Box([14.9585, 16.3038, 15.9327], [3.1473, 4.4126, 5.1101]),
             Box([10.5648, 10.163, 15.7317], [2.1064, 3.749, 3.9398]),
             Box([12.1445, 15.1251, 12.0133], [5.1384, 3.2624, 4.8213], rotation(3.0646, 3.0551, 2.4056))]
    volume = union_sdf(boxes, grid_points(27)).astype(np.float32)
    plain = outward_marching_cubes(volume, 0.0, gradient_direction="ascent", backend="cpu")
    verts, faces = outward_marching_cubes(volume, 0.0, gradient_direction="ascent", backend="cpu",
                                          sharp_features=30)[:2]
    assert len(verts) > len(plain[0])
    assert_closed_manifold(faces)
    assert np.array_equal(np.unique(faces), np.arange(len(verts)))
    assert signed_volume(verts, faces) > 0


def random_boxes(seed):
    """1-3 boxes of random size, place and rotation (a third axis-aligned with faces just off grid planes,
    a third barely rotated), their union's distance field on an n^3 grid, and a spacing."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(24, 33))
    boxes = []
    for _ in range(int(rng.choice([1, 2, 3]))):
        half, centre = rng.uniform(2.0, n / 4.5, 3), rng.uniform(n / 2 - n / 8, n / 2 + n / 8, 3)
        mode = rng.integers(3)
        if mode == 0:
            lo = np.round(centre - half) - rng.uniform(0.0, 0.15, 3) * rng.choice([-1, 1], 3)
            hi = np.round(centre + half) + rng.uniform(0.0, 0.15, 3) * rng.choice([-1, 1], 3)
            boxes.append(Box((lo + hi) / 2, (hi - lo) / 2))
        else:
            spread = 0.15 if mode == 1 else np.pi
            boxes.append(Box(centre, half, rotation(*rng.uniform(-spread, spread, 3))))
    volume = union_sdf(boxes, grid_points(n)).astype(np.float32)
    return volume, tuple(rng.uniform(0.5, 2.0, 3)) if rng.random() < 0.3 else (1.0, 1.0, 1.0)


@pytest.mark.parametrize("seed", [2002, 2004, 2010, 2014, 2031])
def test_random_boxes_give_a_closed_mesh_without_flat_or_unused_pieces(seed):
    # Seeds where a feature point fell on a plain vertex or its base's line (flat fan triangles, now tried
    # as folds: the next candidate point is taken) and where corners' cells surround a grid edge (its
    # vertex, inside the joined patch, had no face: now it splits a fan triangle).
    volume, spacing = random_boxes(seed)
    plain = outward_marching_cubes(volume, 0.0, spacing=spacing, gradient_direction="ascent", backend="cpu")
    verts, faces = outward_marching_cubes(volume, 0.0, spacing=spacing, gradient_direction="ascent", backend="cpu",
                                      sharp_features=30)[:2]
    assert len(verts) > len(plain[0])
    assert_closed_manifold(faces)
    assert np.array_equal(np.unique(faces), np.arange(len(verts)))
    assert triangle_areas(verts, faces).min() > 1e-9
    assert signed_volume(verts, faces) > 0


def test_no_feature_vertex_spikes_out_of_the_rotated_box():
    # Near a corner a cell that took the corner (just outside it) found its fan folded, and fell back on the
    # solver's point, which blended normals put 0.66 cells out of the box: a spike.  Now the fallback is the
    # point on the cell's own edge line, and a solver point far from the sample planes' exact one is none.
    boxes = SCENES["rotated box"]
    volume = union_sdf(boxes, grid_points(N)).astype(np.float32)
    verts = outward_marching_cubes(volume, 0.0, gradient_direction="ascent", backend="cpu", sharp_features=30)[0]
    assert np.abs(union_sdf(boxes, verts.astype(np.float64))).max() <= 0.3  # plain MC's vertices: up to 0.19


def test_few_faces_turn_away_from_the_true_surface(scene):
    # Plain MC has none: each of its faces leans less than 90 degrees from the distance field's gradient at
    # its centre.  A fan to a feature point can turn a face past that (a dark speck or notch on screen);
    # the fold tests keep those under 1% of the faces (the union had 1.7% with FOLD_COS = -0.7).
    boxes = scene["boxes"]
    for name, limit in (("plain", 0.0), ("sharp", 0.01)):
        verts, faces = scene[name][:2]
        tri = verts[faces].astype(np.float64)
        normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        centre, step = tri.mean(axis=1), 1e-4 * np.eye(3)
        gradient = np.stack([union_sdf(boxes, centre + step[k]) - union_sdf(boxes, centre - step[k]) for k in range(3)],
                            axis=1)
        away = np.einsum("fk,fk->f", normal, gradient) < 0
        assert away.mean() <= limit, (name, int(away.sum()), len(faces))


def test_flips_join_feature_vertices_into_lines(scene):
    verts, faces = scene["sharp"][:2]
    n_plain = len(scene["plain"][0])
    edges, _ = edge_use_counts(faces)
    joined = (edges >= n_plain).all(axis=1).sum()
    n_feature = len(verts) - n_plain
    # Along a straight feature line each feature vertex has two feature neighbours: edges ~ vertices.
    assert joined >= 0.8 * n_feature, (joined, n_feature)


BAR_NOT_REACHED = ("issue 9's bar, not reached for this scene (0.29-0.61 cells remain): a corner or edge in a "
                   "cell without a patch, or seen through one sample only; a face split across an edge by the "
                   "sign pattern")


def test_issue_bar_three_times_closer_and_corners_within_a_fifth_of_a_cell(scene, request):
    if request.node.callspec.params["scene"] != "box":
        request.applymarker(pytest.mark.xfail(strict=True, reason=BAR_NOT_REACHED))
    faces_points = on_surface(scene["boxes"], np.concatenate([b.face_points(0.5) for b in scene["boxes"]]))
    worst = {name: max(scene["edge_distance"][name].max(), distance_to_mesh(faces_points, m[0], m[1]).max())
             for name, m in (("plain", scene["plain"]), ("sharp", scene["sharp"]))}
    assert worst["sharp"] * 3 <= worst["plain"]
    assert corner_distances(scene["corners"], scene["sharp"][0]).max() <= 0.2


def test_vertices_next_to_a_kink_move_onto_the_true_surface(scene, request):
    # Between a sample governed by one face of a box and one governed by another, linear interpolation
    # misses the surface (by up to 0.26 cells here); the clean sample plane's crossing is exact where that
    # face is the surface along the edge.  In a union the other box can hide it: a few vertices there
    # (3 of 74) land off by under a tenth of a cell.
    plain, sharp = scene["plain"][0], scene["sharp"][0]
    n_plain = len(plain)
    moved = np.flatnonzero((sharp[:n_plain] != plain).any(axis=1))
    assert len(moved) > 10
    before = np.abs(union_sdf(scene["boxes"], plain[moved].astype(np.float64)))
    after = np.abs(union_sdf(scene["boxes"], sharp[moved].astype(np.float64)))
    assert before.max() > 0.15 and np.median(after) < 1e-4
    if len(scene["boxes"]) == 1:
        assert after.max() < 1e-4
    else:
        worse = after > before + 1e-4
        assert worse.mean() < 0.05 and after.max() < 0.1


def test_a_sphere_gives_exactly_the_plain_mesh():
    points = grid_points(32)
    volume = (np.linalg.norm(points - 15.7, axis=-1) - 10.5).astype(np.float32)
    plain = outward_marching_cubes(volume, 0.0, gradient_direction="ascent", backend="cpu")
    sharp = outward_marching_cubes(volume, 0.0, gradient_direction="ascent", backend="cpu", sharp_features=30)
    for a, b in zip(plain, sharp):
        np.testing.assert_array_equal(a, b)


def test_gpu_mesh_matches_the_numpy_reference(gl_ctx):
    boxes = SCENES["rotated box"]
    volume = (-union_sdf(boxes, grid_points(N))).astype(np.float32)  # density-like: inside above the level
    spacing = (1.0, 0.8, 1.3)
    cpu = outward_marching_cubes(volume, 0.0, spacing=spacing, backend="cpu", sharp_features=40)
    gpu = outward_marching_cubes(volume, 0.0, spacing=spacing, backend="gpu", sharp_features=40)
    assert len(cpu[0]) > len(outward_marching_cubes(volume, 0.0, spacing=spacing, backend="cpu")[0])
    np.testing.assert_array_equal(gpu[1], cpu[1])
    for a, b in zip(gpu[::2], cpu[::2]):
        np.testing.assert_allclose(a, b, atol=1e-5)


def test_a_mesh_too_large_for_one_storage_block_leaves_the_feature_passes_to_numpy(gl_ctx, monkeypatch):
    # Passes 0 and 1 read vertices by index, so they cannot take the vertex buffer a window at a time as
    # the extractor writes it.  With a 16 KiB block limit the mesh needs several: no binding may pass the
    # limit (drivers other than llvmpipe refuse or read garbage), and the mesh is still the reference's.
    from isoscope.gpu.cubes import Extractor
    from isoscope.gpu.limits import GpuLimits
    from isoscope.gpu.sharp_features import sharp_mesh_of
    volume = (-union_sdf(SCENES["rotated box"], grid_points(N))).astype(np.float32)
    real = GpuLimits.of(gl_ctx)
    small = GpuLimits(real.max_3d_texture_size, real.max_texture_size, 16 << 10)
    bound = []
    original = moderngl.Buffer.bind_to_storage_buffer

    def observed(self, binding=0, offset=0, size=-1):
        bound.append(self.size - offset if size < 0 else size)
        return original(self, binding, offset, size)
    monkeypatch.setattr(moderngl.Buffer, "bind_to_storage_buffer", observed)
    with Extractor(volume, ctx=gl_ctx, limits=small) as ex:
        ex.extract(0.0)
        assert ex.n_vertices * 32 > 2 * (16 << 10)  # several blocks' worth
        verts, faces, normals, values, n_plain = sharp_mesh_of(ex, volume, 30.0)
    assert bound and max(bound) <= 16 << 10, f"a {max(bound)}-byte storage block was bound"
    expected = sharpen_extracted(outward_marching_cubes(volume, 0.0, backend="cpu"), volume, (1.0, 1.0, 1.0), True, 30)
    assert len(verts) > n_plain  # features were found
    np.testing.assert_array_equal(faces, expected[1])
    np.testing.assert_allclose(verts, expected[0], atol=1e-5)


@pytest.mark.parametrize("angle", [0, 180, -10, 200, float("nan"), "wide"])
def test_feature_angle_outside_the_open_range_is_refused_in_one_line(angle):
    with pytest.raises(ValueError) as info:
        outward_marching_cubes(np.zeros((3, 3, 3), np.float32) + np.arange(3), 1.0, sharp_features=angle)
    assert "\n" not in str(info.value) and "between 0 and 180" in str(info.value)
    assert check_feature_angle(None) is None and check_feature_angle(30) == 30.0


@pytest.mark.gl
def test_cli_export_and_render_take_sharp(tmp_path):
    plain, sharp = tmp_path / "plain.ply", tmp_path / "sharp.ply"
    for out, extra in ((plain, ()), (sharp, ("--sharp", "30"))):
        result = isoscope_here("export", "box", "--resolution", "24", "--out", out, "--space", "voxel", *extra)
        assert result.returncode == 0, result.stderr
    assert sharp.stat().st_size > plain.stat().st_size
    assert_one_line_error(isoscope_here("export", "box", "--out", tmp_path / "x.ply", "--sharp", "180"), "--sharp")
    assert_one_line_error(isoscope_here("render", "box", "--out", tmp_path / "x.png", "--sharp", "0"), "--sharp")
    assert_one_line_error(isoscope_here("render", "box", "--out", tmp_path / "x.png", "--sharp", "30", "--panel"),
                          "--panel")


@pytest.mark.gl
def test_rendered_box_fills_its_edges_and_corners(tmp_path):
    """Plain MC cuts a box's edges and corners off, so its silhouette is smaller than the box's."""
    from PIL import Image

    def surface_pixels(*extra):
        out = tmp_path / f"box{len(extra)}.png"
        result = isoscope_here("render", "box", "--resolution", "24", "--size", "480x360", "--out", out, *extra)
        assert result.returncode == 0, result.stderr
        rgb = np.asarray(Image.open(out).convert("RGB")).astype(int)
        return ((np.abs(rgb - rgb[0, 0]).sum(axis=-1) > 60) & (rgb[..., 2] > rgb[..., 0] + 30)).sum()

    plain, sharp = surface_pixels(), surface_pixels("--sharp", "30")
    assert sharp >= 1.08 * plain, (plain, sharp)


def smooth_noise(n, seed=3):
    """A smooth random field: a few random plane waves (no sharp features, but bends here and there)."""
    rng = np.random.default_rng(seed)
    points = grid_points(n) / n
    waves = [np.cos(points @ rng.normal(0, 12, 3) + rng.uniform(0, 2 * np.pi)) for _ in range(6)]
    return np.sum(waves, axis=0).astype(np.float32)


GPU_SCENES = {
    **{name: (lambda boxes=boxes: -union_sdf(boxes, grid_points(N))) for name, boxes in SCENES.items()},
    "sphere": lambda: 10.5 - np.linalg.norm(grid_points(N) - 11.7, axis=-1),
    "smooth noise": lambda: smooth_noise(N),
}


@pytest.mark.parametrize("spacing", [(1.0, 1.0, 1.0), (1.0, 0.8, 1.3)])
@pytest.mark.parametrize("name", list(GPU_SCENES))
def test_gpu_feature_points_match_the_numpy_reference(gl_ctx, name, spacing):
    """emc_solve.comp against reference_sharp.patch_points on the same patches (and the meshes they give)."""
    from isoscope import Extractor
    from isoscope.core.sharp.features import sharpen, signed_field
    from isoscope.core.sharp.points import patch_points
    from isoscope.gpu.sharp import SharpExtractor

    volume = GPU_SCENES[name]().astype(np.float32)
    seen = {}

    def recorded(key, solve):
        def run(*args):
            seen[key] = solve(*args)
            return seen[key]
        return run

    with Extractor(volume, spacing=spacing, ctx=gl_ctx) as ex:
        ex.extract(0.0)
        mesh, field, gpu = ex.read_mesh(), signed_field(volume, True), SharpExtractor(ex)
        try:
            cpu_mesh = sharpen(mesh, field, spacing, 30, solver=recorded("cpu", patch_points))
            gpu_mesh = sharpen(mesh, field, spacing, 30, solver=recorded("gpu", gpu.patch_points))
        finally:
            gpu.release()
    if name == "sphere":
        assert not seen and len(cpu_mesh[0]) == cpu_mesh[4]  # no feature patch at all
        return
    (cpu_points, cpu_ok, cpu_corner), (gpu_points, gpu_ok, gpu_corner) = seen["cpu"], seen["gpu"]
    assert len(cpu_points) > 0 and cpu_ok.any()
    np.testing.assert_array_equal(gpu_ok, cpu_ok)
    np.testing.assert_allclose(gpu_points, cpu_points, rtol=0, atol=1e-9)
    np.testing.assert_allclose(gpu_corner, cpu_corner, rtol=0, atol=1e-9)  # nan where rank < 3, on both
    np.testing.assert_array_equal(gpu_mesh[1], cpu_mesh[1])
    for a, b in zip(gpu_mesh[::2], cpu_mesh[::2]):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-5)


def test_viewer_mesh_without_features_is_the_extractors_own(gl_ctx):
    """SharpenedMesh draws the extractor's buffers where no feature is found (nothing uploaded), and
    its own upload where one is; either way read_mesh() is the cpu backend's mesh."""
    from isoscope import Extractor
    from isoscope.gpu.sharp_features import SharpenedMesh

    for name in ("sphere", "box"):
        volume = GPU_SCENES[name]().astype(np.float32)
        with Extractor(volume, ctx=gl_ctx) as ex:
            shown = SharpenedMesh(gl_ctx)
            try:
                for level in (0.0, 0.5, 0.0):
                    ex.extract(level)
                    shown.take(ex, volume, 30)
                    assert (shown.mesh.vertex_buffer is ex.vertex_buffer) == (name == "sphere")
                    cpu = outward_marching_cubes(volume, level, sharp_features=30, backend="cpu")
                    np.testing.assert_array_equal(shown.read_mesh()[1], cpu[1])
                    assert shown.n_vertices == len(cpu[0])
            finally:
                shown.release()
            assert ex.read_mesh()[0].shape[0] == ex.n_vertices > 0  # its buffers were not released


def rough_noise(n, seed=5):
    """Gaussian noise blurred a little: bends everywhere, many of them sharper than the feature angle."""
    from scipy.ndimage import gaussian_filter
    return gaussian_filter(np.random.default_rng(seed).standard_normal((n, n, n)), 1.5).astype(np.float32)


BEND_SCENES = {**GPU_SCENES, "rough noise": lambda: rough_noise(N)}


_WIDEST = {}   # by mesh: a scene's four angles share theirs


def widest_opening_per_cell(verts, faces, normals, spacing):
    """(cells' face lists, the largest angle in degrees between two vertex normals of each cell), cells
    found from the faces' centroids (an MC triangle's centroid lies inside its cell); found once a mesh."""
    key = (verts.tobytes(), faces.tobytes(), normals.tobytes(), tuple(spacing))
    if key not in _WIDEST:
        _WIDEST[key] = _widest_opening_per_cell(verts, faces, normals, spacing)
    return _WIDEST[key]


def _widest_opening_per_cell(verts, faces, normals, spacing):
    cells = np.floor(verts[faces].mean(axis=1) / np.asarray(spacing)).astype(np.int64)
    _, cell_of_face = np.unique(cells, axis=0, return_inverse=True)
    cell_of_face = cell_of_face.reshape(-1)
    groups = np.split(np.argsort(cell_of_face, kind="stable"), np.flatnonzero(np.diff(np.sort(cell_of_face))) + 1)
    # each cell's distinct vertices, padded to the most any cell has, then every pair's dot product at once
    pairs = np.unique(np.stack([np.repeat(cell_of_face, 3), faces.reshape(-1)], axis=1), axis=0)
    starts = np.searchsorted(pairs[:, 0], np.arange(len(groups)))
    slot = np.arange(len(pairs)) - starts[pairs[:, 0]]
    n = np.full((len(groups), slot.max() + 1, 3), np.nan)
    n[pairs[:, 0], slot] = normals[pairs[:, 1]]
    dots = np.einsum("cik,cjk->cij", n, n)
    widest = np.degrees(np.arccos(np.clip(np.nanmin(dots.reshape(len(groups), -1), axis=1), -1, 1)))
    return [faces[rows] for rows in groups], widest


@pytest.mark.parametrize("angle", [10, 30, 60, 120])
@pytest.mark.parametrize("spacing", [(1.0, 1.0, 1.0), (1.0, 0.8, 1.3)])
@pytest.mark.parametrize("name", list(BEND_SCENES))
def test_bend_pass_flags_every_cell_whose_normals_open_wider_than_the_angle(gl_ctx, name, spacing, angle):
    """emc_flags.comp (pass 0) equals reference_sharp.vertex_may_bend and never misses a cell where two
    vertex normals open wider than the feature angle, the only cells `sharpen` can change; where it
    flags nothing, sharp_mesh_of gives the numpy reference's (plain) mesh without running it."""
    from isoscope import Extractor
    from isoscope.core.sharp.cells import vertex_may_bend
    from isoscope.core.sharp.features import sharpen, signed_field
    from isoscope.gpu.sharp import SharpExtractor
    from isoscope.gpu.sharp_features import sharp_mesh_of

    volume = BEND_SCENES[name]().astype(np.float32)
    with Extractor(volume, spacing=spacing, ctx=gl_ctx) as ex:
        ex.extract(0.0)
        verts, faces, normals, values = mesh = ex.read_mesh()
        gpu = SharpExtractor(ex)
        try:
            flags, any_flag = gpu.may_bend(angle, each=True), gpu.may_bend(angle)
            fast = sharp_mesh_of(ex, volume, angle, gpu=gpu)
        finally:
            gpu.release()
    field = signed_field(volume, True)
    np.testing.assert_array_equal(flags, vertex_may_bend(verts, normals, field, spacing, angle))
    assert any_flag == flags.any()
    cell_faces, widest = widest_opening_per_cell(verts, faces, normals, spacing)
    missed = [i for i in np.flatnonzero(widest > angle) if not flags[cell_faces[i]].any()]
    assert not missed, f"{len(missed)} bent cells not flagged, e.g. opening {widest[missed[0]]:.1f} deg"
    reference = sharpen(mesh, field, spacing, angle)
    np.testing.assert_array_equal(fast[1], reference[1])
    for a, b in zip(fast, reference):  # exact where nothing bends; else the GPU solve's points (~1e-14 off)
        np.testing.assert_allclose(a, b, rtol=0, atol=0 if not any_flag else 1e-5)
    if name == "sphere" and angle >= 30:
        assert not any_flag  # the pass does let the plain mesh through where nothing bends
    if name not in ("sphere", "smooth noise") and angle <= 60:
        assert (widest > angle).any()  # the scenes do test the bound


def test_bend_pass_flags_vertices_a_smoothing_moved_off_the_grid_edges(gl_ctx):
    """Pass 0 tests a vertex against the cells of the edge it lies on; after smoothing most vertices lie on
    no edge, and those say 'may bend' (the numpy step then runs, as before pass 0), like the mirror."""
    from isoscope import Extractor
    from isoscope.core.sharp.cells import vertex_may_bend
    from isoscope.core.sharp.features import signed_field
    from isoscope.gpu.sharp import SharpExtractor
    from isoscope.gpu.smooth import Smoother

    volume = GPU_SCENES["sphere"]().astype(np.float32)
    with Extractor(volume, ctx=gl_ctx) as ex:
        ex.extract(0.0)
        gpu, smoother = SharpExtractor(ex), Smoother(ex)
        try:
            assert gpu.may_bend(30) is False  # the plain sphere bends nowhere (None: not run)
            smoother.smooth(ex.mesh, 3)
            flags = gpu.may_bend(30, each=True)
            verts, _, normals, _ = ex.read_mesh()
        finally:
            gpu.release()
            smoother.release()
    on_an_edge = (np.abs(verts - np.rint(verts)) > 1e-3).sum(axis=1) == 1  # (unit spacing)
    assert (~on_an_edge).sum() > len(verts) // 2 and flags[~on_an_edge].all()
    np.testing.assert_array_equal(flags, vertex_may_bend(verts, normals, signed_field(volume, True), (1, 1, 1), 30))


def _turned_over(verts, faces, normals):
    """Faces whose winding's normal is over 120 degrees from the sum of their corners' normals."""
    face_normals = np.cross(verts[faces[:, 1]] - verts[faces[:, 0]], verts[faces[:, 2]] - verts[faces[:, 0]])
    corner_normals = normals[faces].sum(axis=1)
    cos = np.einsum("ij,ij->i", face_normals, corner_normals) / np.maximum(
        np.linalg.norm(face_normals, axis=1) * np.linalg.norm(corner_normals, axis=1), 1e-30)
    return int((cos < -0.5).sum())


def _quantised_scan(size, sigma):
    """An 8-bit scan of a smooth field: noise blurred and rounded to 0..255, and its median level."""
    from scipy.ndimage import gaussian_filter
    field = gaussian_filter(np.random.default_rng(3).normal(size=(size,) * 3), sigma)
    scan = np.round((field - field.min()) / (field.max() - field.min()) * 255).astype(np.uint8)
    return scan, float(np.median(scan))


@pytest.mark.parametrize("size, sigma", [(48, 2.0), (64, 2.5)])
def test_a_quantised_scan_never_turns_a_plain_vertex_normal_inside_out(size, sigma):
    # The sides' own (ENO) normals replace the blended ones around features; on noise an ENO stencil can
    # point into the object, and the faces around it were then shaded from behind (5-12 vertices here,
    # 5,400 on the MNI T1).  No side of a feature turns more than 90 degrees from the blend of both.
    scan, level = _quantised_scan(size, sigma)
    plain = outward_marching_cubes(scan, level, backend="cpu")
    sharp = outward_marching_cubes(scan, level, backend="cpu", sharp_features=30)
    n_plain = len(plain[0])
    assert len(sharp[0]) - n_plain > 1000
    turned = np.einsum("ij,ij->i", sharp[2][:n_plain].astype(np.float64), plain[2].astype(np.float64))
    assert (turned > 0.0).all(), f"{int((turned <= 0).sum())} plain vertices' normals turned inside out"
    assert (turned < 0.9999).sum() > 1000  # and the side normals did replace many blended ones


@pytest.mark.parametrize("size, sigma", [(48, 2.0), (64, 2.5)])
def test_the_drawn_sharp_mesh_shades_no_triangle_from_behind(size, sigma):
    # crisp_normals (what the viewer and `render --sharp` draw): every corner of every triangle has a
    # normal within 90 degrees of the triangle's own, else the triangle renders dark from the front.
    scan, level = _quantised_scan(size, sigma)
    verts, faces, normals, values, n_plain = sharpen_extracted(outward_marching_cubes(scan, level, backend="cpu"),
                                                                scan, (1.0, 1.0, 1.0), True, 30)
    drawn_verts, drawn_faces, drawn_normals, _ = crisp_normals(verts, faces, normals, values, n_plain)
    assert (faces >= n_plain).any(axis=1).sum() > 1000
    corners = drawn_verts[drawn_faces].astype(np.float64)
    face = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    facing = np.einsum("fck,fk->fc", drawn_normals[drawn_faces].astype(np.float64), face)
    assert (facing >= 0).all(), f"{int((facing < 0).any(axis=1).sum())} triangles shaded from behind"
    # the drawn mesh is the same surface: same triangles, corner by corner
    np.testing.assert_array_equal(drawn_verts[drawn_faces], verts[faces])


@pytest.mark.parametrize("size, sigma", [(48, 2.0), (64, 2.5)])
def test_a_quantised_scan_keeps_its_fans_from_turning_over(size, sigma):
    # An 8-bit scan of a smooth field: noise blurred and rounded to 0..255.  Many cells look bent, and a
    # fan to a point beyond its patch's loop turns triangles over (drawn as dark blotches): the point
    # must retreat, or the patch stay plain.  Once ~430-530 such faces here, against 3-12 in plain MC.
    scan, level = _quantised_scan(size, sigma)
    plain = outward_marching_cubes(scan, level, backend="cpu")
    sharp = outward_marching_cubes(scan, level, backend="cpu", sharp_features=30)
    n_feature = len(sharp[0]) - len(plain[0])
    assert n_feature > 1000  # the test means something: many feature vertices
    assert _turned_over(*sharp[:3]) <= _turned_over(*plain[:3]) + 0.005 * n_feature


def test_a_patch_with_no_valid_plane_is_no_feature_and_warns_nothing():
    import warnings

    from isoscope.core.sharp.qef import feature_points
    positions = np.array([[[0.2, 0.5, 0.5], [0.8, 0.5, 0.5], [0.5, 0.5, 0.9]]] * 2)
    normals = np.array([[[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]]] * 2)
    valid = np.array([[True, True, True], [False, False, False]])
    lower, upper = np.zeros((2, 3)), np.ones((2, 3))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # numpy's 'invalid value encountered in divide' fails the test
        points, ok, corners, kinds = feature_points(positions, normals, valid, lower, upper)
    assert ok.tolist() == [True, False] and kinds[0] == 3
    np.testing.assert_allclose(points[0], [0.2, 0.5, 0.9])  # where the three planes meet


def test_a_third_side_exactly_at_the_feature_angle_is_not_one():
    # Two sides at right angles and a third normal tilted out of their plane by the feature angle to within
    # rounding (sin 30 = 0.5, as whole-number ENO differences on an 8-bit scan give it): not a third side,
    # whatever the last bit of the arithmetic, so numpy and the GPU's doubles agree (they took it opposite
    # ways on the MNI T1); a degree more out of the plane is one.
    from isoscope.core.sharp.points import _extreme_normals
    cos_angle = np.cos(np.radians(30.0))
    for z, expected in ((np.nextafter(np.sqrt(1 - cos_angle ** 2), 1.0), False), (np.sin(np.radians(31.0)), True)):
        third = np.array([0.0, np.sqrt(1 - z * z), z])
        normals = np.array([[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], third]])
        keep = _extreme_normals(normals, np.ones((1, 3), bool), cos_angle)
        assert keep[0, 2] == expected, (z, keep)

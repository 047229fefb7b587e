"""The viewer's coarse view of an OME-Zarr pyramid level sits where the file's translations put it: a level of
f^3 block means has its sample i at the centre of its block, (f - 1) / 2 full samples in (ome-zarr-py writes
that translation), so its surface, drawn (mesh.vert's origin) or ray cast (the box and the texture placed at
the origin), lies on the full level's.  Pixel facts: the silhouette's centre in the picture, against the full
level's drawn the same way from the same camera; without the offset it would be (f - 1) / 2 samples off."""
from __future__ import annotations

import dataclasses
import itertools

import numpy as np
import pytest
from support.ome_zarr import half_block_translations, mean_levels, with_translations, write_ome

from isoscope.viewer.gfx.brick_surface import CoarseSplit
from isoscope.viewer.model.big_volume import from_level
from isoscope.viewer.model.style import SurfaceStyle
from isoscope.viewer.ui.headless import HeadlessViewer
from isoscope.volumes import open_volume

N = 64
CENTRE = (31.3, 30.6, 32.2)
RADIUS = 20.0
SIZE = (320, 320)
BACKGROUND = np.round(255 * np.array(SurfaceStyle().background))


@pytest.fixture(scope="module")
def pyramid(tmp_path_factory):
    """A ball's signed distance, N^3 float32, with levels of 2^3 and 4^3 block means translated by their blocks'
    centres ((f - 1) / 2 x the full spacing), opened by isoscope."""
    grid = np.indices((N, N, N), dtype=np.float64)
    ball = (RADIUS - np.sqrt(sum((g - c) ** 2 for g, c in zip(grid, CENTRE)))).astype(np.float32)
    path = tmp_path_factory.mktemp("offset") / "ball.ome.zarr"
    write_ome(path, mean_levels(ball, 3), [[2.0 ** k] * 3 for k in range(3)], chunk=16)
    return open_volume(str(with_translations(path, half_block_translations(3))))


@pytest.fixture
def viewer(gl_ctx):
    made = HeadlessViewer(SIZE, ctx=gl_ctx, memory_budget="1G")
    made.state.style.show_box = False
    yield made
    made.release()


def silhouette_centre(viewer, volume, raycast) -> np.ndarray:
    """(column, row) of the centre of what is not background, `volume` drawn (or ray cast, iso) at 0 from the
    side (+x), the camera fitted to the full level's box whatever is shown."""
    viewer.show(volume, 0.0)
    viewer.camera.fit((0.0, 0.0, 0.0), (N - 1.0,) * 3, 20.0, 10.0)
    viewer.state.set_raycast("iso" if raycast else None)
    image = viewer.render().astype(int)
    rows, columns = np.nonzero(np.abs(image - BACKGROUND).max(axis=2) > 8)
    assert len(rows) > 1000
    return np.array([columns.mean(), rows.mean()])


@pytest.mark.parametrize("raycast", [False, True], ids=["mesh", "rays"])
def test_a_mean_level_s_coarse_view_is_drawn_on_the_full_level_s_surface(viewer, pyramid, raycast):
    full = silhouette_centre(viewer, pyramid, raycast)
    for level, factor in zip(pyramid.pyramid, (2, 4)):
        shown, _ = from_level(pyramid, level)
        assert shown.origin == ((factor - 1) / 2,) * 3
        placed = silhouette_centre(viewer, shown, raycast)
        unplaced = silhouette_centre(viewer, dataclasses.replace(shown, origin=(0.0, 0.0, 0.0)), raycast)
        off = np.linalg.norm(unplaced - full)   # (f - 1) / 2 samples along each axis, on screen
        assert off > 1.0, (level.name, off)
        assert np.linalg.norm(placed - full) < 0.25 * off, (level.name, placed - full, off)


def test_the_coarse_remainder_between_bricks_is_placed_at_the_origin_and_split_where_its_cells_lie(pyramid):
    """Bricks (brick_surface.py): the coarse mesh's triangles go to the bricks of their coarse cells as before,
    and its vertices (the remainder drawn and the skirts' rim) are moved by the view's origin."""
    import isoscope
    shown, step = from_level(pyramid, pyramid.pyramid[0])
    arrays = isoscope.api.outward_marching_cubes(shown.data, 0.0, spacing=shown.spacing, backend="cpu")
    plain = CoarseSplit(arrays, shown.spacing, step, 16, (4, 4, 4))
    placed = CoarseSplit(arrays, shown.spacing, step, 16, (4, 4, 4), shown.origin)
    np.testing.assert_array_equal(placed.brick, plain.brick)
    np.testing.assert_allclose(placed.arrays[0], arrays[0] + np.float32(0.5), atol=1e-5)
    np.testing.assert_allclose(placed.rim.ends, plain.rim.ends + np.float32(0.5), atol=1e-5)


def test_the_probe_on_a_coarse_view_names_the_full_level_s_point_and_its_own_voxel(viewer, pyramid, gl_ctx):
    """The cursor probe (picking.py) draws the meshes at their origin too: on a coarse view it hits the full
    level's surface, its world point is the full level's, and its voxel is the coarse sample under it."""
    from isoscope.viewer.gfx.picking import Picker
    picker = Picker(gl_ctx)
    viewport, pixel = (0, 0, *SIZE, 0), (SIZE[0] // 2 + 7, SIZE[1] // 2 - 5)
    try:
        silhouette_centre(viewer, pyramid, False)
        full = picker.probe(viewer.scene, viewer.camera, viewport, pixel)
        for level in pyramid.pyramid:
            shown, _ = from_level(pyramid, level)
            silhouette_centre(viewer, shown, False)
            probe = picker.probe(viewer.scene, viewer.camera, viewport, pixel)
            assert probe.on == "surface" and probe.space == full.space == "OME-Zarr"
            assert np.linalg.norm(np.subtract(probe.point, full.point)) < 0.25, level.name
            assert np.linalg.norm(np.subtract(probe.world, full.world)) < 0.25, level.name
            index = (np.asarray(probe.point) - shown.origin) / shown.spacing
            assert probe.voxel == tuple(int(v) for v in np.rint(index))
            assert probe.value == shown.data[probe.voxel]
    finally:
        picker.release()


@pytest.mark.parametrize("raycast", [False, True], ids=["mesh", "rays"])
def test_in_bricks_the_coarse_view_and_the_full_level_s_bricks_meet_where_the_file_puts_them(gl_ctx, pyramid,
                                                                                            raycast):
    """Over a budget of 1M the coarse view is level 1 and the bricks in view that fit come from level 0 (3 of 8
    for the meshes): drawn or ray cast (BRICKED: the box from the origin, the coarse texture and its skipping
    bricks read from there) the silhouette is the full level's shown whole, from the same camera."""
    pictures = []
    budget = "1M"
    for memory in (budget, "1G"):
        viewer = HeadlessViewer(SIZE, ctx=gl_ctx, memory_budget=memory)
        try:
            viewer.state.style.show_box = False
            centre = silhouette_centre(viewer, pyramid, raycast)
            assert (viewer.state.bricks is not None) == (memory == budget)
            pictures.append((centre, viewer.render().astype(int)))
        finally:
            viewer.release()
    (bricked_centre, bricked), (whole_centre, whole) = pictures
    difference = np.abs(bricked - whole).max(axis=2)
    assert np.linalg.norm(bricked_centre - whole_centre) < 0.15, bricked_centre - whole_centre
    assert np.count_nonzero(difference > 8) < 0.002 * difference.size


def test_rays_in_bricks_skip_no_full_sample_in_the_strip_a_shifted_coarse_brick_reaches_over_a_seam(
        gl_ctx, tmp_path, monkeypatch):
    """Rays in bricks over a translated pyramid (4^3 means, 1.5 full samples in): the coarse view's skipping
    bricks start at its origin, so the one a ray crosses in a brick read coarse reaches 1.5 full samples into
    the next brick, read in full.  A sheet one full sample thick lies in that strip (x = 33, just past the seam
    at 32; its means are a quarter of it, below the level): iso rays that cross the bricks of x < 32 coarse
    (they cannot be read) and meet the sheet in a brick read in full stop on it, as the whole volume's rays do
    (model/ray_bricks.py widens every shifted brick a full brick's cells reach into)."""
    import isoscope.viewer.model.ray_bricks as ray_bricks
    n, level = 96, 0.6
    data = np.zeros((n, n, n), np.float32)
    data[33, 4:92, 4:92] = 1.0
    path = tmp_path / "sheet.ome.zarr"
    write_ome(path, mean_levels(data, 3), [[2.0 ** k] * 3 for k in range(3)], chunk=16)
    volume = open_volume(str(with_translations(path, half_block_translations(3))))
    read = ray_bricks.read_ray_brick

    def unreadable_below_the_seam(data, brick, *args, **kwargs):
        if brick.index[0] == 0:
            raise OSError("a damaged chunk")
        return read(data, brick, *args, **kwargs)
    monkeypatch.setattr(ray_bricks, "read_ray_brick", unreadable_below_the_seam)

    def pictured(budget):
        viewer = HeadlessViewer(SIZE, ctx=gl_ctx, memory_budget=budget)
        viewer.state.style.show_box = False
        viewer.show(volume, level)
        viewer.state.set_raycast("iso")
        camera = viewer.camera
        camera.fit((0.0, 0.0, 0.0), (n - 1.0,) * 3, 0.0, 0.0)
        azimuth = min((0.0, 90.0, 180.0, 270.0), key=lambda a: (camera.look_from(a, 8.0), camera.eye()[0])[1])
        camera.look_from(azimuth, 8.0)
        for _ in range(4):   # the bricks below the seam fail once each, the others come
            viewer.state.error = None
            picture = viewer.render().astype(int)
        return viewer, picture

    viewer, bricked = pictured("2M")
    try:
        rays = viewer.state.bricks.rays
        assert viewer.state.step == 4 and viewer.state.volume.origin == (1.5, 1.5, 1.5)
        assert rays.shift == (1.5, 1.5, 1.5) and rays.range_cells == 32 and rays.layout.cells == 32
        full = [index for index in rays.loaded if index[0] == 1]
        assert full and all(index[0] != 0 for index in rays.loaded), sorted(rays.loaded)
        camera = viewer.camera
    finally:
        viewer.release()
    whole_viewer, whole = pictured("1G")
    whole_viewer.release()
    width, height = SIZE
    checked = set()
    for _, j, k in full:   # the sheet's points inside the bricks read in full, a few samples from their edges
        for y, z in itertools.product(range(32 * j + 4, 32 * j + 29, 3), range(32 * k + 4, 32 * k + 29, 3)):
            if 8 <= y < 88 and 8 <= z < 88:   # off the sheet's rim
                clip = np.array([33.0, y, z, 1.0]) @ camera.view_matrix() @ camera.projection_matrix(width / height)
                x_ndc, y_ndc = clip[:2] / clip[3]
                checked.add((int((1 - y_ndc) / 2 * height), int((x_ndc + 1) / 2 * width)))
    rows, columns = np.array(sorted(checked)).T
    inside = (0 <= rows) & (rows < height) & (0 <= columns) & (columns < width)
    rows, columns = rows[inside], columns[inside]
    sheet = np.abs(whole[rows, columns] - BACKGROUND).max(axis=1) > 8   # the whole volume's rays meet the sheet
    assert np.count_nonzero(sheet) > 0.9 * len(checked) > 100, (np.count_nonzero(sheet), len(checked))
    rows, columns = rows[sheet], columns[sheet]
    missed = np.abs(bricked[rows, columns] - BACKGROUND).max(axis=1) <= 8
    assert not missed.any(), (np.count_nonzero(missed), len(rows))
    # the same sheet: lit within a few levels (its gradient at the seam takes the coarse view's samples below it)
    difference = np.abs(bricked[rows, columns] - whole[rows, columns]).max(axis=1)
    assert np.count_nonzero(difference > 24) <= 0.01 * len(rows), (difference.max(), len(rows))


def test_colour_by_reads_the_same_texel_for_a_placed_mesh_and_a_moved_one(viewer, gl_ctx, pyramid):
    """A coarse view's mesh is drawn placed by the look's origin (whole) or with its vertices moved already (the
    bricks' coarse remainder, look origin 0): coloured by a second volume (a steep ramp along x, on the view's
    grid), both give the same picture.  The moved one sampled the texture off by origin / spacing."""
    from isoscope.viewer.gfx.colorby import GpuColorBy
    from isoscope.viewer.gfx.cpu_surface import CpuMesh
    from isoscope.viewer.gfx.renderer import SurfaceLook
    from isoscope.viewer.model.colorby import make_color_by
    shown, _ = from_level(pyramid, pyramid.pyramid[1])            # 4^3 means: origin 1.5 samples
    steep = np.arange(shown.data.shape[0], dtype=np.float32)[:, None, None]
    ramp = dataclasses.replace(shown, data=np.broadcast_to(steep, shown.data.shape).copy(), name="ramp")
    viewer.show(shown, 0.0)
    viewer.state.style.lighting = False                             # flat colours: the map's colour alone
    arrays = viewer.scene.surface.shown.read_mesh()
    moved = (arrays[0] + np.asarray(shown.origin, np.float32), *arrays[1:])
    colours = GpuColorBy(gl_ctx, make_color_by(shown, "volume", "viridis", ramp))
    meshes = [CpuMesh(gl_ctx), CpuMesh(gl_ctx)]
    pictures = []
    try:
        for mesh, data, origin in zip(meshes, (arrays, moved), (shown.origin, (0.0, 0.0, 0.0))):
            mesh.take(data, 0.0, 0.0)
            viewer.target.use()
            viewer.renderer.draw([mesh.mesh], viewer.camera, viewer.target.viewport, viewer.state.style,
                                 looks=[SurfaceLook((1.0, 1.0, 1.0), 1.0, colours, origin)])
            pictures.append(viewer.target.read_rgb().astype(int))
    finally:
        colours.release()
        for mesh in meshes:
            mesh.release()
    placed, moved_picture = pictures
    covered = np.abs(placed - BACKGROUND).max(axis=2) > 8
    assert covered.sum() > 1000
    assert np.abs(placed - moved_picture).max(axis=2)[covered].mean() < 1.0

"""The viewer's coarse view of an OME-Zarr pyramid level sits where the file's translations put it: a level of
f^3 block means has its sample i at the centre of its block, (f - 1) / 2 full samples in (ome-zarr-py writes
that translation), so its surface, drawn (mesh.vert's origin) or ray cast (the box and the texture placed at
the origin), lies on the full level's.  Pixel facts: the silhouette's centre in the picture, against the full
level's drawn the same way from the same camera; without the offset it would be (f - 1) / 2 samples off."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import zarr
from support.ome_zarr import mean_levels, write_ome

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
    group = zarr.open_group(str(path), mode="r+")
    multiscales = group.attrs["multiscales"]
    for k, dataset in enumerate(multiscales[0]["datasets"]):
        dataset["coordinateTransformations"].append({"type": "translation", "translation": [(2 ** k - 1) / 2] * 3})
    group.attrs["multiscales"] = multiscales
    return open_volume(str(path))


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

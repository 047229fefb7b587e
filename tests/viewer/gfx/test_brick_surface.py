"""A volume over the memory budget shown in bricks (issue 33, point 3): the coarse view at once, the bricks
in view refined to full resolution, skirts where the two levels meet, the Stats line and `shown_shape`."""
from __future__ import annotations

import time

import numpy as np
import pytest
from support.brick_seams import chequer_seams
from support.mesh_checks import edge_uses, triangles

import isoscope
from isoscope.core.bricks import brick_grid, brick_layout, bricks_of, face_neighbours
from isoscope.core.budget import MemoryBudget
from isoscope.core.skirts import edges_used_once, rim_of, skirt
from isoscope.viewer.gfx import brick_surface
from isoscope.viewer.ui.headless import HeadlessViewer
from isoscope.volumes.inputs import as_volume

brick_surface_skirt = brick_surface.skirt
SHAPE = (160, 160, 160)
BUDGET = "20M"        # the whole (29.7 MiB to show) does not fit; a coarse view at step 2 and 64^3 bricks do,
#                       all 27 refined on llvmpipe (its copy of the coarse image counted: 16M held 27 before)
LEVEL = 0.7


@pytest.fixture(scope="module")
def blob():
    """An ellipsoid with bumps 8 samples apart, 160^3 float32 samples, values falling outwards: its coarse
    view (every 2nd sample) and full resolution differ by a good part of a sample, so cracks would show."""
    axis = np.linspace(-1, 1, SHAPE[0], dtype=np.float32)
    x, y, z = np.meshgrid(axis, axis, axis, indexing="ij")
    k = 2 * np.pi / (8 * 2 / (SHAPE[0] - 1))
    bumps = 0.03 * np.sin(k * x) * np.sin(k * y) * np.sin(k * z)
    return (1.0 - np.sqrt(x * x + 1.3 * y * y + 0.8 * z * z) - bumps).astype(np.float32)


@pytest.fixture
def viewer(gl_ctx, blob):
    viewer = HeadlessViewer((480, 360), ctx=gl_ctx, memory_budget=BUDGET)
    viewer.show(as_volume(blob, name="blob"), 1.0 - LEVEL)
    yield viewer
    viewer.release()


# --- pure parts --------------------------------------------------------------------------------------
def test_the_layout_keeps_coarse_cells_inside_bricks_and_several_bricks_in_the_room():
    layout = brick_layout(SHAPE, 4, MemoryBudget(16 << 20, "test"))
    assert layout.step == 2 and layout.cells % layout.step == 0 and layout.cells == 64
    assert layout.work <= layout.room / 4 and layout.room > 0
    assert brick_grid(SHAPE, layout.cells) == (3, 3, 3) and bricks_of(SHAPE, layout.cells)[-1].index == (2, 2, 2)
    too_small = r"below what one \d+\^3 brick at full resolution needs beside the coarse view"
    with pytest.raises(isoscope.IsoscopeError, match=too_small):
        brick_layout((4000, 4000, 4000), 4, MemoryBudget(4 << 20, "test"))


def test_face_neighbours_name_the_brick_across_each_face_and_none_at_the_border():
    bricks = bricks_of((9, 9, 9), 4)
    grid = brick_grid((9, 9, 9), 4)
    middle = bricks[7]   # index (1, 1, 1): cells 4..8, the last along each axis
    assert middle.index == (1, 1, 1) and middle.first == (4, 4, 4) and middle.end == (8, 8, 8)
    ends = np.array([[[4, 5.5, 6], [4, 6, 6.5]],      # on its lower x face: (0, 1, 1)
                     [[5, 8, 4.5], [5.5, 8, 5]],       # on its upper y face: the border (no brick 2 along y)
                     [[5, 5.5, 6], [5.5, 6, 6.5]]])    # inside it
    np.testing.assert_array_equal(face_neighbours(ends, middle, grid, (1, 1, 1), 4),
                                  [np.ravel_multi_index((0, 1, 1), grid), -1, -1])


def test_a_skirt_folds_the_rim_down_keeping_the_orientation():
    # two triangles of a plane z = 1 facing +z (counter-clockwise seen from above), cut at x = 1
    verts = np.array([[0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], np.float32)
    faces = np.array([[0, 1, 2], [0, 2, 3]])
    normals = np.tile(np.float32([0, 0, 1]), (4, 1))
    rim = rim_of(verts, faces, normals, np.arange(4, dtype=np.float32))
    assert len(rim) == 4 and len(edges_used_once(faces)) == 4
    on_cut = np.flatnonzero(np.all(rim.ends[:, :, 0] == 1, axis=1))
    s_verts, s_faces, s_normals, _ = skirt(rim.subset(on_cut), 0.5)
    assert len(s_faces) == 2 and np.all(s_normals == [0, 0, 1])
    np.testing.assert_allclose(sorted(set(s_verts[:, 2])), [0.5, 1.0])        # down, against the winding normal
    # the fold keeps the orientation: the shared edge is used once each way by the plane and its skirt
    joined = np.concatenate([verts, s_verts])
    directed = set()
    for face in np.concatenate([faces, s_faces + len(verts)]):
        for i in range(3):
            directed.add((tuple(joined[face[i]]), tuple(joined[face[(i + 1) % 3]])))
    a, b = (1.0, 0.0, 1.0), (1.0, 1.0, 1.0)
    assert (a, b) in directed and (b, a) in directed
    # and the skirt faces away from the plane's side of the cut (+x)
    tri = s_verts[s_faces[0]]
    assert np.cross(tri[1] - tri[0], tri[2] - tri[0])[0] > 0


# --- in the viewer -----------------------------------------------------------------------------------
def test_the_coarse_view_shows_at_once_and_says_so(viewer):
    state, scene = viewer.state, viewer.scene
    assert state.step == 2 and state.volume.data.shape == (80, 80, 80) and state.bricks is not None
    assert any("along each axis, the bricks in view refined to full resolution" in note for note in state.volume.notes)
    assert scene.stats.shown_shape == (80, 80, 80)
    assert state.bricks.text.startswith("0 of 27 bricks at full resolution")


def test_with_the_whole_volume_in_view_every_brick_is_refined_into_the_whole_volume_mesh(viewer, blob):
    viewer.render()
    state, scene = viewer.state, viewer.scene
    assert state.bricks.text == "27 of 27 bricks at full resolution (27 of 27 in view)"
    assert scene.stats.shown_shape == SHAPE
    shown = triangles(mesh.read()[:2] for mesh in scene.stats.meshes)
    verts, faces, _, _ = isoscope.api.outward_marching_cubes(blob, 1.0 - LEVEL)
    whole = triangles([(verts, faces)])
    assert len(whole) > 50_000 and shown == whole
    uses = edge_uses(shown)
    assert set(uses.values()) == {2}   # watertight across the brick seams: every edge in two triangles


def test_looking_at_one_corner_refines_only_the_bricks_in_view(viewer):
    camera = viewer.camera
    camera.target = np.array([8.0, 8.0, 8.0])   # close to the corner at the origin, looking into it
    camera.distance = 30.0
    viewer.render(panel=True)
    bricks = viewer.state.bricks
    refined = set(bricks.meshes)
    assert (0, 0, 0) in refined and 0 < len(refined) < 27
    assert refined <= bricks.visible and len(bricks.visible) < 27
    assert viewer.state.bricks.text.startswith(f"{len(refined)} of 27 bricks at full resolution")
    assert viewer.scene.stats.shown_shape == SHAPE   # every brick in view is at full resolution
    camera.fit(*viewer.state.bounds())           # the whole in view again: more bricks than the room holds?
    viewer.render()
    assert viewer.scene.stats.shown_shape == SHAPE and len(bricks.meshes) == 27


def test_the_coarse_remainder_is_ranges_of_one_index_buffer_written_once(viewer):
    """The coarse mesh's triangles go up once, in order of their brick; as bricks are refined the remainder is
    drawn as ranges of that buffer (no buffer written again), and the ranges hold exactly the coarse triangles
    of the bricks not refined."""
    camera = viewer.camera
    camera.target = np.array([8.0, 8.0, 8.0])
    camera.distance = 30.0
    app, bricks, surface = viewer.app, viewer.state.bricks, viewer.scene.bricks
    buffers, sizes = set(), []
    for _ in range(200):
        app.follow(0.02)
        if surface._coarse:
            buffers.add(surface._coarse_triangles)   # held: a buffer made again is another object
            sizes.append(sum(mesh.n_triangles for mesh in surface._coarse))
        if bricks.meshes and bricks.refining is None and not bricks.to_load:
            break
        time.sleep(0.01)
    assert len(buffers) == 1 and sizes[0] > sizes[-1] and len(bricks.meshes) < 27
    split = surface._split
    refined = {bricks.flat[index] for index in bricks.meshes}
    expected = split.arrays[1][~np.isin(split.brick, list(refined))]
    drawn = np.concatenate([mesh.read()[1] for mesh in surface._coarse])
    assert sorted(map(tuple, drawn)) == sorted(map(tuple, expected))
    assert len(surface._coarse) <= len(refined) + 1


def test_bricks_come_a_few_a_frame_from_a_worker_and_a_new_level_starts_again(viewer):
    app, bricks = viewer.app, viewer.state.bricks
    counts, deadline = [], time.monotonic() + 120
    while len(bricks.meshes) < 27 and time.monotonic() < deadline:
        app.follow(0.02)                        # the window's frames: never waiting for a brick
        counts.append(len(bricks.meshes))
        time.sleep(0.01)
    assert len(bricks.meshes) == 27 and counts[0] == 0
    assert max(np.diff(counts)) == 1             # one brick a frame at most: the frame never waits for many
    assert viewer.scene.stats.shown_shape == SHAPE
    viewer.state.iso = 1.0 - 0.6                  # the level moves: back to the coarse mesh, bricks again at rest
    app.follow(0.02)
    assert len(bricks.meshes) == 0 and viewer.scene.stats.shown_shape == (80, 80, 80)


@pytest.mark.parametrize("skirts", [True, False])
def test_seams_between_levels_show_no_background_and_no_inside(viewer, monkeypatch, skirts):
    """A chequer of bricks at full resolution and coarse: where both the all-coarse and the all-fine pictures
    show the outside of the surface, the mixed one shows neither the background nor (but for a few pixels at
    thin bumps, where a skirt's back shows) the inside's colour through a crack.  Without skirts (depth 0)
    the cracks show: the test can tell."""
    if not skirts:
        monkeypatch.setattr(brick_surface, "skirt", lambda rim, depth: brick_surface_skirt(rim, 0.0))
    viewer.camera.distance = 200.0                # the ellipsoid fills most of the picture
    seams = chequer_seams(viewer)
    assert len(viewer.state.bricks.meshes) == 14
    drawn_pixels, holes, cracks = seams.drawn, seams.holes, seams.cracks
    assert drawn_pixels > 50_000 and holes <= 10
    if skirts:
        assert cracks <= drawn_pixels * 0.0005, cracks
    else:
        assert cracks > drawn_pixels * 0.0006, cracks


@pytest.mark.gl   # render needs a GL context
def test_render_says_what_it_draws_of_a_volume_over_the_budget(blob, tmp_path, gl_ctx):
    """`render --memory-budget` under what the volume's meshes take says, on stderr, from how many samples the
    surface is drawn and how many bricks are at full resolution; where every brick in view is refined (20M: all
    27 fit, as above) or the whole fits, it says nothing of the kind."""
    from support.command import isoscope_here
    np.save(tmp_path / "blob.npy", blob)
    said = {}
    for budget in ("8M", BUDGET, "4G"):
        result = isoscope_here("render", tmp_path / "blob.npy", "--iso", str(1.0 - LEVEL), "--memory-budget", budget,
                               "--out", tmp_path / f"{budget}.png")
        assert result.returncode == 0, result.stderr
        said[budget] = [line for line in result.stderr.splitlines() if "the surface is drawn from" in line]
    assert said[BUDGET] == [] and said["4G"] == []
    from isoscope.gpu.context import is_software_renderer
    software = is_software_renderer(gl_ctx)   # the command's GL is this one's: llvmpipe counts its image copies
    layout = brick_layout(SHAPE, 4, MemoryBudget(8 << 20, "--memory-budget", software))
    coarse = "x".join(str(len(range(0, n, layout.step))) for n in SHAPE)
    (line,) = said["8M"]
    assert line.startswith(f"note: the surface is drawn from {coarse} of 160x160x160 samples")
    assert "8.0 MiB (--memory-budget)" in line
    refined, total = (int(n) for n in line.split("; ")[1].split(" bricks")[0].split(" of "))
    assert 0 < refined < total == len(bricks_of(SHAPE, layout.cells))


def test_a_render_plans_its_bricks_for_its_own_shape(gl_ctx, blob):
    """A wide picture (4:1) close to the volume sees bricks at its sides that a 4:3 picture would not: the first
    render plans for the picture's shape (it was planned for 4:3 before anything was drawn)."""
    from isoscope.core.bricks import in_view
    viewer = HeadlessViewer((960, 240), ctx=gl_ctx, memory_budget=BUDGET)
    try:
        viewer.show(as_volume(blob, name="blob"), 1.0 - LEVEL)
        camera, bricks = viewer.camera, viewer.state.bricks
        camera.look_from(0.0, 0.0)
        camera.distance *= 0.25                    # close: bricks at the sides are in the wide picture only
        viewer.render()
        spacing = viewer.state.full_volume.spacing
        seen = {}
        for aspect in (4.0, 4 / 3):
            clip = (camera.view_matrix().astype(np.float64) @ camera.projection_matrix(aspect)).T
            seen[aspect] = {b.index for b, v in zip(bricks.bricks, in_view(bricks.bricks, spacing, clip)) if v}
        assert seen[4.0] != seen[4 / 3]           # the case: the two shapes see different bricks
        assert bricks.visible == seen[4.0]
    finally:
        viewer.release()


def test_a_new_volume_draws_and_counts_without_the_last_one_s_bricks(viewer, blob):
    viewer.render()
    assert viewer.scene.bricks.drawing and len(viewer.state.bricks.meshes) == 27
    viewer.show(as_volume(blob[:40, :40, :40].copy(), name="small"), 1.0 - LEVEL)   # fits the budget whole
    scene = viewer.scene
    assert viewer.state.bricks is None and not scene.bricks.drawing
    assert scene.stats.shown_shape == (40, 40, 40)
    assert all(mesh is not part for mesh, _ in scene.drawn() for part in scene.bricks.meshes)
    assert scene.bricks.meshes == []


def test_a_volume_over_the_budget_says_how_it_is_ray_cast(gl_ctx, blob, tmp_path):
    """The rays of a volume over the budget read its bricks in view at full resolution and the coarse view
    elsewhere (test_ray_bricks.py draws it): the panel's Stats and `render` say so in a line; a volume that fits
    says nothing of it, nor do surfaces alone."""
    from support.command import isoscope_here

    from isoscope.viewer.model.raycast import rays_note

    def notes(volume, budget):
        """The notes without rays and with a MIP."""
        viewer = HeadlessViewer((160, 120), ctx=gl_ctx, memory_budget=budget)
        try:
            viewer.show(volume, 1.0 - LEVEL)
            said = [rays_note(viewer.state)]
            viewer.state.set_raycast("mip")
            viewer.render()
            return [*said, rays_note(viewer.state)], viewer.state.volume
        finally:
            viewer.release()
    said, coarse = notes(as_volume(blob, name="blob"), BUDGET)
    whole_said, _ = notes(as_volume(coarse.data, spacing=coarse.spacing, name="blob"), None)
    shape = "x".join(map(str, coarse.data.shape))
    assert said[0] is None and whole_said == [None, None] and shape != "160x160x160"
    assert said[1].startswith("the volume is ray cast at full resolution in its bricks read so far, ")
    assert said[1].endswith(f"of 27 in view), and from {shape} of 160x160x160 samples elsewhere (what the memory "
                            "budget lets in)")
    np.save(tmp_path / "blob.npy", blob)
    result = isoscope_here("render", tmp_path / "blob.npy", "--raycast", "mip", "--memory-budget", BUDGET,
                           "--out", tmp_path / "mip.png")
    assert result.returncode == 0, result.stderr
    assert "note: the volume is ray cast at full resolution in its bricks read so far" in result.stderr


def test_a_level_only_the_bricks_show_is_not_said_empty(gl_ctx):
    """Lines one sample thick at odd indices: the coarse view (every 2nd sample) has no surface at 0.5, the
    bricks at full resolution do. The Stats' triangles count what is drawn, and no hint says the level empty."""
    from isoscope.viewer.ui.headless import empty_level_hints
    data = np.zeros(SHAPE, np.float32)
    for k in range(25, 135, 10):
        data[k, 20:140, 81] = 1.0
    viewer = HeadlessViewer((160, 120), ctx=gl_ctx, memory_budget=BUDGET)
    try:
        viewer.show(as_volume(data, name="lines"), 0.5)
        assert viewer.state.step == 2 and viewer.scene.stats.n_triangles == 0
        assert empty_level_hints(viewer)   # the coarse view alone: nothing at 0.5, and said so
        viewer.render()
        drawn = sum(mesh.n_triangles for mesh in viewer.scene.stats.meshes)
        assert drawn > 0 and viewer.scene.stats.n_triangles == drawn and viewer.scene.stats.n_vertices > 0
        assert viewer.scene.stats.level_stats(0)[0] == drawn and empty_level_hints(viewer) == []
    finally:
        viewer.release()

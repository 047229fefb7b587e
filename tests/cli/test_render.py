"""The scene as pixels: headless EGL renders of real extractions, checked on the images."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from support.command import isoscope_here

from isoscope.viewer.ui.headless import HeadlessViewer
from isoscope.volumes import open_volume

SIZE = (160, 120)


@pytest.fixture
def viewer(gl_ctx):
    headless = HeadlessViewer(SIZE, ctx=gl_ctx)
    headless.state.style.show_box = False   # measure the surface alone
    yield headless
    headless.release()


def small_sphere():
    # Signed distance to a sphere of radius 0.7 in [-1, 1]^3, negative inside ("ascent").
    return open_volume("sphere", resolution=40)


def surface_mask(image: np.ndarray, background) -> np.ndarray:
    background = np.round(np.array(background) * 255)
    return np.abs(image.astype(int) - background).max(axis=2) > 3


def brightness(image: np.ndarray) -> np.ndarray:
    return image.astype(float).mean(axis=2)


def test_sphere_renders_as_a_lit_disc(viewer):
    viewer.show(small_sphere(), iso=0.0, azimuth=0, elevation=0)
    image = viewer.render()
    mask = surface_mask(image, viewer.state.style.background)

    background = np.round(np.array(viewer.state.style.background) * 255)
    for corner in (image[:6, :6], image[:6, -6:], image[-6:, :6], image[-6:, -6:]):
        assert (corner == background).all()

    rows, cols = np.nonzero(mask)
    centre = rows.mean(), cols.mean()
    radius = (cols.max() - cols.min() + 1) / 2
    assert abs(centre[0] - SIZE[1] / 2) < 3 and abs(centre[1] - SIZE[0] / 2) < 3
    # Round: a disc's area is pi r^2 (a square of side 2r would be 27% more).
    assert mask.sum() == pytest.approx(np.pi * radius ** 2, rel=0.08)

    # Headlight: faces towards the eye are brightest; the limb is darker.
    distance = np.hypot(*np.indices(mask.shape) - np.array(centre)[:, None, None])
    light = brightness(image)
    centre_light = light[mask & (distance < 0.3 * radius)].mean()
    limb_light = light[mask & (distance > 0.85 * radius)].mean()
    assert centre_light > limb_light + 40


def test_larger_iso_gives_a_larger_disc_and_reuses_the_viewer(viewer):
    viewer.show(small_sphere(), iso=-0.2, azimuth=0, elevation=0)
    small = surface_mask(viewer.render(), viewer.state.style.background).sum()
    small_triangles = viewer.scene.stats.n_triangles
    viewer.state.iso = 0.2   # radius 0.5 -> 0.9: the mesh grows, the extractor may reallocate
    large = surface_mask(viewer.render(), viewer.state.style.background).sum()
    assert viewer.scene.stats.n_triangles > 2 * small_triangles
    assert large / small == pytest.approx((0.9 / 0.5) ** 2, rel=0.15)


def test_inside_out_surface_shows_the_back_colour(viewer):
    sphere = small_sphere()
    viewer.show(sphere, iso=0.0, azimuth=0, elevation=0)
    front = viewer.render()
    flipped = dataclasses.replace(sphere, gradient_direction="descent")   # claims the outside is the object
    viewer.show(flipped, iso=0.0, azimuth=0, elevation=0)
    back = viewer.render()
    mask = surface_mask(front, viewer.state.style.background)
    front_rgb, back_rgb = front[mask].mean(axis=0), back[mask].mean(axis=0)
    assert front_rgb[2] > front_rgb[0] + 30     # default front colour is blue
    assert back_rgb[0] > back_rgb[2] + 30       # default back colour is orange


def test_lighting_toggle_gives_flat_colour_and_wireframe_draws_lines(viewer):
    viewer.show(small_sphere(), iso=0.0)
    lit = viewer.render()
    viewer.state.style.lighting = False
    flat = viewer.render()
    mask = surface_mask(lit, viewer.state.style.background)
    inner = mask & np.roll(mask, 2, 0) & np.roll(mask, -2, 0) & np.roll(mask, 2, 1) & np.roll(mask, -2, 1)
    expected = np.round(np.array(viewer.state.style.front_color) * 255)
    assert np.abs(flat[inner] - expected).max() <= 1
    assert brightness(lit)[inner].std() > 10

    viewer.state.style.wireframe = True
    wired = viewer.render()
    changed = np.abs(wired.astype(int) - flat.astype(int)).max(axis=2) > 10
    assert changed[inner].mean() > 0.1
    near_surface = mask | np.roll(mask, 1, 0) | np.roll(mask, -1, 0) | np.roll(mask, 1, 1) | np.roll(mask, -1, 1)
    assert not changed[~near_surface].any()   # lines stay on the surface (give or take the silhouette pixel)


def test_bounding_box_is_drawn(viewer):
    viewer.show(small_sphere(), iso=-0.5)
    without_box = viewer.render()
    viewer.state.style.show_box = True
    with_box = viewer.render()
    changed = np.abs(with_box.astype(int) - without_box.astype(int)).max(axis=2) > 30
    assert changed.sum() > 200


def cube_records(centre, half=0.3) -> tuple[np.ndarray, np.ndarray]:
    """A closed cube as the extractor's vertex records (position, value, normal, pad) and
    outward, counter-clockwise triangles: made here, by hand, not by any extractor."""
    corners = np.array([[(i >> k) & 1 for k in range(3)] for i in range(8)], np.float32) * 2 - 1
    quads = [(0, 1, 3, 2), (4, 5, 7, 6), (0, 1, 5, 4), (2, 3, 7, 6), (0, 2, 6, 4), (1, 3, 7, 5)]
    faces = []
    for a, b, c, d in quads:
        for tri in ((a, b, c), (a, c, d)):
            p = corners[list(tri)]
            if np.dot(np.cross(p[1] - p[0], p[2] - p[0]), p.mean(axis=0)) < 0:  # wind it outwards
                tri = tri[::-1]
            faces.append(tri)
    records = np.zeros((8, 8), np.float32)
    records[:, :3] = np.asarray(centre, np.float32) + half * corners
    records[:, 3] = 42.0  # a value the renderer must skip
    records[:, 4:7] = corners / np.linalg.norm(corners, axis=1, keepdims=True)
    return records, np.array(faces, np.uint32)


def test_the_renderer_draws_any_gpu_mesh_record(viewer, gl_ctx):
    from isoscope.gpu.mesh import GpuMesh
    viewer.show(small_sphere(), iso=0.0, azimuth=0, elevation=0)  # only for the camera framing
    viewer.state.style.lighting = False                            # flat colours: exact pixel facts
    style, camera = viewer.state.style, viewer.camera
    owned, meshes = [], []
    for dz in (-0.45, 0.45):  # one below the other about the view's centre: z is up on the screen
        records, faces = cube_records(camera.target + (0, 0, dz))
        vbo, ibo = gl_ctx.buffer(records.tobytes()), gl_ctx.buffer(faces.tobytes())
        owned += [vbo, ibo]
        meshes.append(GpuMesh(vbo, ibo, len(records), len(faces)))

    def draw(drawn):
        viewer.target.use()
        viewer.renderer.draw(drawn, camera, viewer.target.viewport, style)
        return viewer.target.read_rgb()
    try:
        nothing, low, both = draw([]), draw(meshes[:1]), draw(meshes)
    finally:
        for buffer in owned:
            buffer.release()
    front = np.round(255 * np.array(style.front_color)).astype(int)
    assert not surface_mask(nothing, style.background).any()
    low_rows = np.nonzero((np.abs(low.astype(int) - front) <= 2).all(axis=2))[0]
    both_rows = np.nonzero((np.abs(both.astype(int) - front) <= 2).all(axis=2))[0]
    assert len(low_rows) > 200                                      # outward winding: front colour
    assert len(both_rows) == pytest.approx(2 * len(low_rows), rel=0.05)
    assert low_rows.min() > SIZE[1] / 2 > both_rows.min()           # the second cube is above the first


def test_a_transparent_background_gives_alpha_only_where_the_scene_is(gl_ctx, tmp_path):
    from PIL import Image

    from isoscope.viewer.ui.headless import render_png
    volume = small_sphere()
    opaque = HeadlessViewer(SIZE, ctx=gl_ctx)
    try:
        opaque.show(volume, iso=0.0)
        scene = surface_mask(opaque.render(), opaque.state.style.background)
    finally:
        opaque.release()
    path = render_png(volume, tmp_path / "clear.png", iso=0.0, size=SIZE, transparent=True)
    image = Image.open(path)
    assert image.mode == "RGBA"
    rgba = np.asarray(image)
    drawn = rgba[:, :, 3] > 0
    assert (drawn & scene).sum() / (drawn | scene).sum() > 0.97     # the same pixels, no background
    assert rgba[0, 0, 3] == 0 and rgba[-1, -1, 3] == 0
    inner = rgba[rgba[:, :, 3] == 255][:, :3].astype(int)            # straight alpha: lit surface colours
    assert len(inner) > 100 and inner.mean(axis=0)[2] > inner.mean(axis=0)[0]   # bluish front colour


def test_screenshots_may_be_larger_than_any_window(gl_ctx):
    viewer = HeadlessViewer((2560, 1440), ctx=gl_ctx)
    try:
        viewer.show(small_sphere(), iso=0.0)
        image = viewer.render()
    finally:
        viewer.release()
    assert image.shape == (1440, 2560, 3)
    assert surface_mask(image, viewer.state.style.background).mean() > 0.02


def test_a_failed_png_write_keeps_the_old_file(tmp_path, monkeypatch):
    from PIL import Image

    from isoscope.viewer.gfx.screenshot import save_png
    target = tmp_path / "shot.png"
    target.write_bytes(b"the good screenshot")

    def half_written(self, fp, *args, **kwargs):
        fp.write(b"\x89PNG half")
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(Image.Image, "save", half_written)
    with pytest.raises(OSError):
        save_png(np.zeros((4, 4, 3), np.uint8), target)
    assert target.read_bytes() == b"the good screenshot"
    assert [p.name for p in tmp_path.iterdir()] == ["shot.png"]


def test_a_headless_render_leaves_the_shared_context_working(gl_ctx, tmp_path):
    # render_png once made a second standalone context, which stayed current: programs the
    # shared context had compiled then ran in the wrong one and found no triangles.
    from isoscope.cpu.cubes import marching_cubes_reference
    from isoscope.gpu.cubes import Extractor
    from isoscope.viewer.ui.headless import render_png
    field = small_sphere().data
    expected = marching_cubes_reference(field, 0.0, descent=False)[1]

    def extract():
        with Extractor(field, ctx=gl_ctx, gradient_direction="ascent") as ex:
            ex.extract(0.0)
            return ex.read_mesh()[1]
    np.testing.assert_array_equal(extract(), expected)              # the shared context's programs
    render_png(small_sphere(), tmp_path / "first.png", iso=0.0, size=(64, 48))
    faces = extract()
    assert len(faces) == len(expected) > 1000
    np.testing.assert_array_equal(faces, expected)


@pytest.mark.gl
def test_render_of_an_empty_level_says_why_on_stderr(tmp_path):
    """A blank picture with exit 0 said nothing; the panel's hint for an empty level is printed as a note."""
    data = np.zeros((16, 16, 16), np.float32)
    data[4:12, 4:12, 4:12] = 1.0
    np.save(tmp_path / "box.npy", data)
    empty = isoscope_here("render", tmp_path / "box.npy", "--iso", "0", "--out", tmp_path / "e.png")
    assert empty.returncode == 0, empty.stderr
    assert empty.stderr.strip().startswith("note: no surface at 0") and "the values lie in" in empty.stderr
    drawn = isoscope_here("render", tmp_path / "box.npy", "--iso", "0.5", "--out", tmp_path / "d.png")
    assert drawn.returncode == 0 and "no surface" not in drawn.stderr, drawn.stderr

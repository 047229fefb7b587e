"""Direct volume rendering by ray casting (gfx/raycast.py, shaders/raycast.*), by pixel facts: MIP shows a
bright ball hidden inside a dimmer one where the surface between them cannot; the iso mode's silhouette is
the mesh's; MIP >= mean >= MinIP on every pixel; DVR of a uniform block follows Beer-Lambert with its
depth, and DVR is lit across the gradient; MIP straight down an axis is numpy's max along it; OpenGL 4.1
draws what 4.3 draws; the command, Python and scenes agree; a bad mode is one line."""
from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest
from PIL import Image
from support.command import isoscope_here

import isoscope
from isoscope.viewer.gfx.raycast import DENSITY_PER_SAMPLE
from isoscope.viewer.gfx.slices import colormap_rgba8
from isoscope.viewer.model.colormaps import LUT_SIZE
from isoscope.viewer.model.style import SurfaceStyle
from isoscope.viewer.ui.headless import HeadlessViewer
from isoscope.volumes.inputs import as_volume

pytestmark = pytest.mark.gl
SIZE = (200, 150)
BACKGROUND = np.round(255 * np.array(SurfaceStyle().background))


def _grid(n=48):
    axis = np.linspace(-1, 1, n)
    return np.meshgrid(axis, axis, axis, indexing="ij")


def nested() -> np.ndarray:
    """A dim ball (0.4) with a bright one (1.0) inside it, off centre."""
    x, y, z = _grid()
    outer = np.where(np.sqrt(x * x + y * y + z * z) < 0.8, 0.4, 0.0)
    inner = np.where(np.sqrt((x - 0.2) ** 2 + y * y + z * z) < 0.25, 0.6, 0.0)
    return (outer + inner).astype(np.float32)


@pytest.fixture
def viewer(gl_ctx):
    made = HeadlessViewer(SIZE, ctx=gl_ctx)
    yield made
    made.release()


def picture(viewer, mode, level=0.2, window=(1.0, 0.5)):
    viewer.state.set_raycast(mode)
    viewer.state.slices.set_window(*window)
    viewer.state.iso = level
    return viewer.picture().astype(int)


def white(image) -> int:
    return int(np.count_nonzero((image >= 250).all(axis=2)))


def test_mip_shows_a_bright_ball_that_the_surface_between_them_hides(viewer):
    viewer.show(as_volume(nested()), 0.2)
    assert white(picture(viewer, None)) == 0   # the level 0.2 surface: the dim ball, lit blue
    mip = picture(viewer, "mip")
    assert white(mip) > 100                    # the bright ball, through the dim one
    ys, xs = np.nonzero((mip >= 250).all(axis=2))
    assert abs(ys.mean() - SIZE[1] / 2) < 25 and abs(xs.mean() - SIZE[0] / 2) < 40


def test_mip_mean_and_minip_order_on_every_pixel(viewer):
    viewer.show(as_volume(nested()), 0.2)
    mip, mean, minip = (picture(viewer, mode)[..., 0] for mode in ("mip", "mean", "minip"))
    inside = mip != BACKGROUND[0]
    assert inside.sum() > 1000
    assert (mip[inside] >= mean[inside] - 1).all() and (mean[inside] >= minip[inside] - 1).all()
    assert (mip[inside] > minip[inside]).any()


def test_the_iso_mode_has_the_meshs_silhouette(viewer):
    x, y, z = _grid(40)
    ball = (0.7 - np.sqrt(x * x + 1.5 * y * y + z * z)).astype(np.float32)
    viewer.show(as_volume(ball), 0.0)
    mesh, iso = picture(viewer, None, 0.0), picture(viewer, "iso", 0.0)
    drawn = [(np.abs(image - BACKGROUND).max(axis=2) > 30) for image in (mesh, iso)]
    union, both = (drawn[0] | drawn[1]).sum(), (drawn[0] & drawn[1]).sum()
    assert both > 2000 and both / union > 0.97, both / union


@pytest.mark.parametrize("depth", [8, 16])
def test_dvr_of_a_uniform_block_follows_beer_lambert_with_its_depth(viewer, depth):
    """Seen from above, the centre ray crosses the block's whole depth, (depth - 1) samples: what reaches the
    eye is the background times exp(-sigma L) plus white times the rest."""
    block = np.ones((24, 24, depth), np.float32)
    block[0, 0, 0] = 0.0   # not constant (a volume must vary); far from the centre ray
    viewer.show(as_volume(block), 0.5, azimuth=0.0, elevation=90.0)
    image = picture(viewer, "dvr", 0.5, window=(1.0, 0.5))
    transmitted = np.exp(-DENSITY_PER_SAMPLE * (depth - 1))
    expected = 255 * (1 - transmitted) + BACKGROUND * transmitted
    centre = image[SIZE[1] // 2, SIZE[0] // 2]
    assert np.abs(centre - expected).max() <= 3, (centre, expected)


def test_the_command_python_and_a_scene_draw_the_same_picture(tmp_path):
    np.save(tmp_path / "nested.npy", nested())
    options = ("--iso", "0.2", "--window", "1", "--level", "0.5", "--size", "200x150")
    done = isoscope_here("render", tmp_path / "nested.npy", "--raycast", "mip", *options,
                         "--out", tmp_path / "cli.png", "--save-scene", tmp_path / "s.json")
    assert done.returncode == 0, done.stderr
    assert json.loads((tmp_path / "s.json").read_text())["raycast"] == "mip"
    again = isoscope_here("render", "--scene", tmp_path / "s.json", "--out", tmp_path / "scene.png")
    assert again.returncode == 0, again.stderr
    cli = np.asarray(Image.open(tmp_path / "cli.png"))
    assert np.array_equal(cli, np.asarray(Image.open(tmp_path / "scene.png")))
    api = isoscope.render(nested(), 0.2, size=(200, 150), raycast="mip")   # its window: the default percentiles
    assert api.shape == (150, 200, 4)
    assert white(cli) > 50 and white(api[..., :3]) > 50


@pytest.mark.parametrize("mode", ["mip", "minip", "mean", "iso", "dvr"])
def test_opengl_41_draws_what_43_draws(tmp_path, mode):
    np.save(tmp_path / "nested.npy", nested())
    env = {**os.environ, "MESA_GL_VERSION_OVERRIDE": "4.1", "MESA_GLSL_VERSION_OVERRIDE": "410"}
    pictures = {}
    for name, environment in (("41", env), ("43", dict(os.environ))):
        environment = {k: v for k, v in environment.items() if name == "41" or not k.startswith("MESA_GL")}
        done = subprocess.run([sys.executable, "-m", "isoscope", "render", tmp_path / "nested.npy", "--raycast", mode,
                               "--iso", "0.2", "--window", "1", "--level", "0.5", "--size", "160x120",
                               "--out", tmp_path / f"{name}.png"], env=environment, capture_output=True, text=True,
                              timeout=120)
        assert done.returncode == 0, done.stderr
        pictures[name] = np.asarray(Image.open(tmp_path / f"{name}.png")).astype(int)
    assert np.abs(pictures["41"] - pictures["43"]).max() <= 2
    assert np.abs(pictures["43"] - BACKGROUND).max() > 50


def test_python_render_is_the_commands_picture(tmp_path):
    np.save(tmp_path / "nested.npy", nested())
    for mode in ("mip", "dvr"):
        done = isoscope_here("render", tmp_path / "nested.npy", "--raycast", mode, "--iso", "0.2", "--size", "200x150",
                             "--out", tmp_path / f"{mode}.png")
        assert done.returncode == 0, done.stderr
        api = isoscope.render(nested(), 0.2, size=(200, 150), raycast=mode)
        assert np.array_equal(api[..., :3], np.asarray(Image.open(tmp_path / f"{mode}.png"))), mode


def test_a_bad_mode_is_one_line_everywhere(viewer, tmp_path):
    with pytest.raises(isoscope.IsoscopeError, match="volume rendering 'xyz' is not one of mip"):
        viewer.state.set_raycast("xyz")
    with pytest.raises(isoscope.IsoscopeError, match="xyz"):
        isoscope.render(nested(), 0.2, size=(64, 48), raycast="xyz")
    done = isoscope_here("render", "sphere", "--raycast", "xyz", "--out", tmp_path / "x.png")
    assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1 and "--raycast" in done.stderr


@pytest.mark.parametrize("mode", ["mip", "minip", "iso", "dvr"])
def test_skipping_empty_bricks_changes_no_pixel(gl_ctx, monkeypatch, mode):
    """The picture with 8^3-cell bricks left where they cannot change a ray's result, alone or macro bricks of
    4^3 (or 3^3 of 4^3-cell) bricks looked at first, equals the picture with one brick for the whole volume
    (nothing skippable), within a grey level."""
    import isoscope.viewer.gfx.raycast as raycast
    x, y, z = _grid(40)
    field = np.where(np.sqrt(x * x + y * y + z * z) < 0.6, 1.0 - x * x - y * y, 0.0).astype(np.float32)
    pictures = []
    for brick, macro in ((10**6, 1), (8, 1), (8, 4), (4, 3)):
        monkeypatch.setattr(raycast, "BRICK", brick)
        monkeypatch.setattr(raycast, "MACRO", macro)
        viewer = HeadlessViewer(SIZE, ctx=gl_ctx)
        try:
            viewer.show(as_volume(field), 0.5)
            pictures.append(picture(viewer, mode, 0.5, window=(1.0, 0.5)))
        finally:
            viewer.release()
    for skipping in pictures[1:]:
        assert np.abs(skipping - pictures[0]).max() <= 1
    assert np.abs(pictures[0] - BACKGROUND).max() > 50   # something was drawn


def test_macro_brick_ranges_are_the_ranges_of_bricks_that_many_times_larger():
    """coarser_ranges(brick_ranges(a, 8), 4) is brick_ranges(a, 32): the (min, max) a macro brick's rays may meet,
    the partial last ones along each axis too."""
    from isoscope.core.value_ranges import brick_ranges, coarser_ranges
    data = np.random.default_rng(3).normal(size=(70, 41, 33)).astype(np.float32)
    for brick, by in ((8, 4), (4, 3), (5, 2)):
        np.testing.assert_array_equal(coarser_ranges(brick_ranges(data, brick), by), brick_ranges(data, brick * by))


def test_the_clip_plane_cuts_the_rays_and_iso_draws_the_cut(viewer):
    x, y, z = _grid(40)
    ball = (0.7 - np.sqrt(x * x + y * y + z * z)).astype(np.float32)
    viewer.show(as_volume(ball), 0.0)
    whole = picture(viewer, "iso", 0.0)
    viewer.state.slices.set_clip(0, 20.0)   # hide x above the middle
    mesh_cut = picture(viewer, None, 0.0, window=(0.2, -0.1))   # its cap (the slice) white: values >= 0
    iso_cut = picture(viewer, "iso", 0.0)
    # anything but background
    drawn = [(np.abs(image - BACKGROUND).max(axis=2) > 8) for image in (whole, mesh_cut, iso_cut)]
    assert drawn[2].sum() < drawn[0].sum()                    # half the ball is gone
    union, both = (drawn[1] | drawn[2]).sum(), (drawn[1] & drawn[2]).sum()
    assert both / union > 0.95, both / union                  # where the capped mesh is, the cut rays are


@pytest.mark.parametrize("mode", ["mip", "dvr", "iso"])
def test_the_coarse_picture_while_moving_is_the_full_one_stretched(viewer, mode):
    """While the view moves the window casts a ray per 2x2 pixels, each stepping MOVING_STEP times further,
    and stretches the picture: the same picture to within its blur (the bright ball where it is; iso's
    silhouette where it is: its hit is bisected all the same), the background untouched outside the box."""
    viewer.show(as_volume(nested()), 0.2)
    full = picture(viewer, mode)
    viewer.target.use()
    viewer.app.draw(viewer.target.viewport, moving=True)
    coarse = viewer.target.read_rgb().astype(int)
    assert np.abs(coarse - full).mean() < 4, np.abs(coarse - full).mean()
    assert (coarse[0, 0] == BACKGROUND).all() and (coarse[-1, -1] == BACKGROUND).all()
    if mode == "mip":
        assert white(coarse) > 0.6 * white(full) > 50
    if mode == "iso":
        drawn = [np.abs(image - full[0, 0]).max(axis=2) > 30 for image in (full, coarse)]
        assert (drawn[0] & drawn[1]).sum() / (drawn[0] | drawn[1]).sum() > 0.95 and drawn[0].sum() > 2000


def test_a_transfer_function_shows_only_what_it_makes_opaque(viewer):
    """With the dim ball's value (0.4) transparent and the core's (1.0) opaque, DVR shows the core alone:
    where only the dim ball lies the picture is the background; with the window's ramp it is not."""
    viewer.show(as_volume(nested()), 0.2)
    ramp = picture(viewer, "dvr")
    viewer.state.set_transfer("0:0,0.5:0,0.9:1,1:1")
    core = picture(viewer, "dvr")
    dim_only = (np.abs(ramp - BACKGROUND).max(axis=2) > 10) & ~(np.abs(core - BACKGROUND).max(axis=2) > 10)
    assert dim_only.sum() > 1000                     # the dim ball's rim: drawn with the ramp, gone now
    assert (np.abs(core - BACKGROUND).max(axis=2) > 40).sum() > 50   # the core is there
    assert viewer.state.transfer == ((0.0, 0.0), (0.5, 0.0), (0.9, 1.0), (1.0, 1.0))


@pytest.mark.parametrize("spec, words", [
    ("0.6:1,0.5:0", "must go up in value"), ("5:1,6:1", "outside the volume's values 0 .. 1"),
    ("0:0,1:2", "opacity 2 at 1 is not 0..1"), ("junk", "not VALUE:OPACITY"), ("0:1", "2 to 64"),
])
def test_bad_transfer_functions_are_one_line(viewer, tmp_path, spec, words):
    viewer.show(as_volume(nested()), 0.2)
    with pytest.raises(isoscope.IsoscopeError, match=words):
        viewer.state.set_transfer(spec)
    assert viewer.state.transfer is None
    with pytest.raises(isoscope.IsoscopeError, match=words) as refused:   # the Python door
        isoscope.render(nested(), 0.2, size=(64, 48), raycast="dvr", transfer=spec)
    assert "\n" not in str(refused.value)
    np.save(tmp_path / "nested.npy", nested())
    done = isoscope_here("render", tmp_path / "nested.npy", "--raycast", "dvr", "--transfer", spec,
                         "--out", tmp_path / "x.png")
    assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1 and words in done.stderr


@pytest.mark.parametrize("mode", [None, "mip", "iso"])
def test_a_transfer_without_dvr_is_refused_where_one_picture_would_ignore_it(tmp_path, mode):
    """render, movie and isoscope.render draw once: a transfer function with another mode would be dropped
    without a word, so each says so in one line before any work (no GL needed for the refusal)."""
    np.save(tmp_path / "nested.npy", nested())
    flags = ["--raycast", mode] if mode else []
    for command, out in (("render", "x.png"), ("movie", "x.gif")):
        done = isoscope_here(command, tmp_path / "nested.npy", *flags, "--transfer", "0:0,1:1",
                             "--out", tmp_path / out)
        assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1, done.stderr
        assert "add --raycast dvr or leave --transfer out" in done.stderr
        assert not (tmp_path / out).exists()
    with pytest.raises(isoscope.IsoscopeError, match="add raycast='dvr' or leave transfer out"):
        isoscope.render(nested(), 0.2, size=(64, 48), raycast=mode, transfer="0:0,1:1")


def test_presets_fit_the_volumes_range_and_a_scene_keeps_the_transfer(tmp_path):
    from isoscope.viewer.model.raycast import check_transfer
    bone = check_transfer("ct-bone", (-1024.0, 3071.0))
    assert bone[0] == (150.0, 0.0) and [v for v, _ in bone] == sorted(v for v, _ in bone)
    assert check_transfer("mri", (0.0, 255.0))[-1] == (255.0, 0.9)
    np.save(tmp_path / "nested.npy", nested())
    done = isoscope_here("render", tmp_path / "nested.npy", "--raycast", "dvr", "--transfer", "mri",
                         "--out", tmp_path / "a.png", "--save-scene", tmp_path / "s.json")
    assert done.returncode == 0, done.stderr
    assert json.loads((tmp_path / "s.json").read_text())["transfer"][0] == [0.12, 0.0]
    again = isoscope_here("render", tmp_path / "s.json", "--out", tmp_path / "b.png")
    assert again.returncode == 0, again.stderr
    assert np.array_equal(np.asarray(Image.open(tmp_path / "a.png")), np.asarray(Image.open(tmp_path / "b.png")))


def blobs(shape=(40, 48, 36)) -> np.ndarray:
    """Three smooth bumps of different heights (0.9, 0.7, 0.5) at different places: a MIP along any axis
    differs from the others, and within a voxel the field changes by a few grey levels at most."""
    index = np.indices(shape, dtype=np.float64)
    field = np.zeros(shape)
    for height, centre, sigma in ((0.9, (12, 30, 20), 5.0), (0.7, (26, 14, 12), 6.0), (0.5, (22, 30, 26), 4.0)):
        field += height * np.exp(-sum((i - c) ** 2 for i, c in zip(index, centre)) / (2 * sigma * sigma))
    return field.astype(np.float32)


def pixel_centres_on_plane(camera, size, axis, position) -> np.ndarray:
    """(height, width, 3): where the ray through each pixel's centre crosses the plane at `position` along
    `axis`, in model units, from the camera's own matrices (pyrr's row vectors: clip = p @ view @ projection)."""
    width, height = size
    inverse = np.linalg.inv(camera.view_matrix().astype(np.float64)
                            @ camera.projection_matrix(width / height).astype(np.float64))
    x = (np.arange(width) + 0.5) / width * 2 - 1
    y = 1 - (np.arange(height) + 0.5) / height * 2
    ndc = np.stack(np.broadcast_arrays(x[None, :], y[:, None]), axis=-1)
    ends = []
    for z in (-1.0, 1.0):
        points = np.concatenate([ndc, np.full(ndc.shape[:2] + (1,), z), np.ones(ndc.shape[:2] + (1,))], -1) @ inverse
        ends.append(points[..., :3] / points[..., 3:])
    near, far = ends
    t = (position - near[..., axis]) / (far[..., axis] - near[..., axis])
    return near + t[..., None] * (far - near)


@pytest.mark.parametrize("axis, view", [(0, (0.0, 0.0)), (1, (90.0, 0.0)), (2, (0.0, 90.0)), (2, (0.0, -90.0))])
def test_mip_along_an_axis_is_numpys_max_within_a_grey_level(viewer, axis, view):
    """A view straight down an axis through a 0.25-degree field of view from far away (the rays parallel to
    within 1/40 of a voxel across the volume): inside the volume's footprint each pixel is the grey colour map
    at the largest value along the axis of the volume's planes, each sampled bilinearly at the pixel centre."""
    data = blobs()
    viewer.camera.fov_degrees = 0.25
    viewer.show(as_volume(data), 0.5, *view)
    image = picture(viewer, "mip", 0.5, window=(1.0, 0.5))[..., 0]
    inside, expected = numpy_mip(viewer.camera, data, axis)
    difference = np.abs(image[inside] - expected)
    assert difference.max() <= 1, (difference.max(), np.count_nonzero(difference > 1))
    assert np.ptp(expected) > 150   # the picture has something to get wrong


def numpy_mip(camera, data, axis, kept=slice(None)) -> tuple[np.ndarray, np.ndarray]:
    """Where each pixel's ray crosses the volume's footprint along `axis` (away from its rim), and there the
    grey colour map at the largest value along the axis of the planes `kept`, each sampled bilinearly at
    the pixel centre: the picture of a MIP straight down the axis from far away."""
    spot = pixel_centres_on_plane(camera, SIZE, axis, (data.shape[axis] - 1) / 2)
    across = [a for a in range(3) if a != axis]
    u, v = spot[..., across[0]], spot[..., across[1]]
    inside = (u >= 1) & (u <= data.shape[across[0]] - 2) & (v >= 1) & (v <= data.shape[across[1]] - 2)
    assert inside.sum() > 2000
    planes = np.moveaxis(data, axis, -1)[..., kept].astype(np.float64)   # (A, B, along)
    u, v = u[inside], v[inside]
    i, j = np.floor(u).astype(int), np.floor(v).astype(int)
    fu, fv = (u - i)[:, None], (v - j)[:, None]
    bilinear = ((1 - fu) * (1 - fv) * planes[i, j] + fu * (1 - fv) * planes[i + 1, j]
                + (1 - fu) * fv * planes[i, j + 1] + fu * fv * planes[i + 1, j + 1])
    expected = colormap_rgba8("gray")[np.minimum((np.clip(bilinear.max(axis=1), 0, 1) * LUT_SIZE).astype(int),
                                                 LUT_SIZE - 1), 0].astype(int)
    return inside, expected


@pytest.mark.parametrize("hide_above", [True, False])
def test_the_clip_plane_cuts_the_rays_of_a_mip_down_to_numpys_max_over_the_kept_planes(viewer, hide_above):
    """Straight down z (as above), the clip across z at plane 18: MIP is numpy's max over the planes kept
    (0..18 or 18..35) within a grey level, and differs from the whole volume's (the brightest bump lies
    in the hidden half)."""
    data = blobs()
    viewer.camera.fov_degrees = 0.25
    viewer.show(as_volume(data), 0.5, 0.0, 90.0)
    viewer.state.slices.set_clip(2, 18.0, hide_above=hide_above)
    image = picture(viewer, "mip", 0.5, window=(1.0, 0.5))[..., 0]
    inside, expected = numpy_mip(viewer.camera, data, 2, slice(0, 19) if hide_above else slice(18, None))
    difference = np.abs(image[inside] - expected)
    assert difference.max() <= 1, (difference.max(), np.count_nonzero(difference > 1))
    _, whole = numpy_mip(viewer.camera, data, 2)
    assert np.abs(whole - expected).max() > 50


def _sides(viewer) -> tuple[float, float, int]:
    """A smooth ball made nearly opaque from its rim in (a transfer function), in DVR: the mean brightness of
    its upper-left and lower-right halves, and how many pixels it covers."""
    x, y, z = _grid(40)
    ball = np.exp(-(x * x + y * y + z * z) / (2 * 0.35 ** 2)).astype(np.float32)
    viewer.show(as_volume(ball), 0.5)
    viewer.state.set_transfer("0.01:0,0.2:1,0.99:1")
    image = picture(viewer, "dvr", 0.5, window=(0.6, 0.3)).sum(axis=2)
    drawn = np.abs(image - BACKGROUND.sum()) > 30
    ys, xs = np.nonzero(drawn)
    rows, columns = np.indices(image.shape)
    towards_lower_right = (columns - xs.mean()) + (rows - ys.mean())
    lit_side, far_side = (image[drawn & (side > 5)].mean() for side in (-towards_lower_right, towards_lower_right))
    return lit_side, far_side, int(drawn.sum())


def test_dvr_is_lit_across_the_gradient_brighter_on_the_fill_lights_side(viewer):
    """The meshes' fill light comes from the upper left (lighting.glsl), so the ball's upper-left half is
    brighter than its lower-right half; with the lighting toggle off (the panel's, the meshes' too) the two
    are the same to 1%: the ball is round."""
    lit_side, far_side, drawn = _sides(viewer)
    assert drawn > 2000
    assert lit_side > 1.1 * far_side, (lit_side, far_side)
    viewer.state.style.lighting = False
    lit_side, far_side, _ = _sides(viewer)
    assert abs(lit_side - far_side) < 0.01 * far_side, (lit_side, far_side)


def test_the_lighting_toggle_leaves_iso_flat_as_it_leaves_the_mesh(viewer):
    """Lit, the iso mode's ball shades from its rim to its middle as the mesh does; with the panel's lighting
    off both are the surface's colour, flat: inside the silhouette every pixel of either is that colour."""
    x, y, z = _grid(40)
    ball = (0.7 - np.sqrt(x * x + 1.5 * y * y + z * z)).astype(np.float32)
    viewer.show(as_volume(ball), 0.0)
    viewer.state.style.show_box = False
    lit = picture(viewer, "iso", 0.0)
    viewer.state.style.lighting = False
    mesh, iso = picture(viewer, None, 0.0), picture(viewer, "iso", 0.0)
    flat = np.round(255 * np.array(viewer.state.style.front_color))
    inside = _inner(np.abs(mesh - BACKGROUND).max(axis=2) > 30) & _inner(np.abs(iso - BACKGROUND).max(axis=2) > 30)
    assert inside.sum() > 1500
    assert np.ptp(lit[inside][:, 2]) > 60                  # the light's shading, lit
    assert np.abs(iso[inside] - flat).max() <= 1 and np.abs(mesh[inside] - flat).max() <= 1


def _inner(mask, by=2):
    """`mask` less its rim `by` pixels wide: away from edges drawn at subpixel positions."""
    kept = mask.copy()
    for axis in (0, 1):
        for shift in range(1, by + 1):
            kept &= np.roll(mask, shift, axis) & np.roll(mask, -shift, axis)
    return kept


@pytest.mark.parametrize("mode", ["mip", "mean", "dvr"])
def test_an_opaque_surface_hides_the_bright_core_behind_it(viewer, mode):
    """With the surfaces drawn too, the dim ball's surface (level 0.2, opaque) ends the rays: the bright core
    inside it is hidden.  In front of the surface the values are below the level, so the volume there covers
    it by at most that much (MIP, mean: as bright as they are in the window 0..1; DVR: its opacity): inside
    the surface's outline the picture is the surface's own to within 0.2 x 255; where no surface is, the
    rays are as without surfaces."""
    viewer.show(as_volume(nested()), 0.2)
    viewer.state.style.show_box = False   # its lines cross the surface's outline
    surface = picture(viewer, None)
    alone = picture(viewer, mode)
    viewer.state.set_with_surfaces(True)
    both = picture(viewer, mode)
    ball = surface[..., 2] - surface[..., 0] > 30   # the lit blue surface (not the grey box lines)
    inside, outside = _inner(ball), _inner(~ball, 3)
    assert inside.sum() > 1500 and outside.sum() > 3000
    assert np.abs(both[inside] - surface[inside]).max() <= 0.2 * 255 + 1
    assert np.abs(both[outside] - alone[outside]).max() <= 2
    assert np.abs(alone[inside] - surface[inside]).max() > 100   # without the surfaces, the volume there
    if mode == "mip":
        assert white(alone) > 100 and white(both) == 0


@pytest.mark.parametrize("samples", [0, 4])
@pytest.mark.parametrize("clip, blit", [(False, True), (True, True), (False, False), (True, False)])
def test_the_opaque_scene_drawn_once_for_the_rays_is_the_surfaces_own_picture(gl_ctx, request, monkeypatch, clip,
                                                                              blit, samples):
    """With the surfaces, the opaque ones and the slices are drawn once, into a target of their own whose depth
    ends the rays, and copied into the picture (a blit into a render's target; into the window's framebuffer,
    a full-screen pass, sample by sample): under rays that add nothing (DVR, opacity 0 everywhere) the
    picture is the one without rays on every pixel, the surfaces' antialiased edges, a slice and the box's
    lines included, with the clip plane too (the surfaces cut, their cap drawn); and the surface ends the
    rays (MIP's bright core behind it hidden).  Multisampled (a render's 4) or not (the window on llvmpipe)."""
    from isoscope.viewer.gfx.opaque_pass import OpaquePass
    from isoscope.viewer.gfx.renderer import OffscreenTarget
    if not blit:
        monkeypatch.setattr(OpaquePass, "blits_into", staticmethod(lambda *args: False))
    viewer = HeadlessViewer(SIZE, ctx=gl_ctx)
    viewer.target.release()
    viewer.target = OffscreenTarget(gl_ctx, SIZE, samples=samples)
    request.addfinalizer(viewer.release)
    viewer.show(as_volume(nested()), 0.2)
    viewer.state.slices.inset = False
    viewer.state.slices.show(1, True, 30)
    if clip:
        viewer.state.slices.set_clip(0, 30.0)
    plain = picture(viewer, None)
    core = white(picture(viewer, "mip"))                         # the core, without the surfaces
    viewer.state.set_with_surfaces(True)
    if not clip:   # (the clip's cap, a slice through the core, shows it white)
        assert core > 50 and white(picture(viewer, "mip")) == 0   # hidden by the surface
    viewer.state.set_transfer("0:0,1:0")
    both = picture(viewer, "dvr")
    edges = (np.abs(np.diff(plain.sum(axis=2), axis=1)) > 60).sum()
    assert edges > 200                                           # outlines to get wrong
    assert np.abs(both - plain).max() <= 1, (np.abs(both - plain).max(), (np.abs(both - plain) > 1).sum())


def test_a_slice_stays_drawn_and_ends_the_rays(viewer):
    """Seen from above, a slice across the box above the balls (all zeros there): MIP and DVR end at it, so
    the bright core behind it is hidden and the slice shows as it does without ray casting; the clip's cut
    is no slice: with rays alone they are cut by it, not stopped."""
    viewer.show(as_volume(nested()), 0.2, azimuth=0.0, elevation=90.0)
    mip = picture(viewer, "mip")
    viewer.state.slices.inset = False
    viewer.state.slices.show(2, True, 45)
    plain = picture(viewer, None)
    middle = (slice(SIZE[1] // 2 - 25, SIZE[1] // 2 + 25), slice(SIZE[0] // 2 - 25, SIZE[0] // 2 + 25))
    for mode in ("mip", "dvr"):
        ended = picture(viewer, mode)
        assert np.abs(ended[middle] - plain[middle]).max() <= 2, mode
    assert white(mip) > 100 and white(picture(viewer, "mip")) == 0


@pytest.mark.parametrize("mode", ["mip", "dvr"])
def test_translucent_surfaces_are_laid_over_the_volume_last(viewer, mode):
    """The stated order: the opaque scene, the rays over it, then the translucent surfaces over both (OIT's
    resolve: their colour plus what is behind times (1 - opacity) per layer).  So the picture is linear in
    the volume's: with the dim ball's shell at opacity 0.4 (two layers across its middle), changing the
    volume's picture (another window) changes the picture with the shell by 0.6^2 of that, pixel by pixel;
    the shell lies over all of the volume, the bright middle inside it too (MIP and DVR have no one depth).
    A smooth cone (1 at the middle, 0.2 at two thirds of the way out): a binary ball's stepped shell is
    crossed three times on some rays."""
    x, y, z = _grid(48)
    cone = np.clip(1.2 - 1.5 * np.sqrt(x * x + y * y + z * z), 0.0, 1.0).astype(np.float32)
    viewer.show_levels(as_volume(cone), [0.2], opacities=[0.4])
    viewer.state.style.show_box = False
    shell = picture(viewer, None)
    windows = ((1.0, 0.5), (0.5, 0.75))   # (width, centre): 0..1, then 0.5..1
    alone = [picture(viewer, mode, window=window) for window in windows]
    viewer.state.set_with_surfaces(True)
    both = [picture(viewer, mode, window=window) for window in windows]
    inside = _inner(np.abs(shell - BACKGROUND).max(axis=2) > 30, 3)
    changed = inside & (np.abs(alone[0] - alone[1]).max(axis=2) > 30)
    assert changed.sum() > 500
    expected = (1 - 0.4) ** 2 * (alone[0] - alone[1])
    error = np.abs((both[0] - both[1]) - expected)[changed]
    assert error.max() <= 3, (error.max(), np.count_nonzero(error > 3))
    assert np.abs(both[0] - alone[0])[inside].max() > 30   # the shell is there


@pytest.mark.parametrize("coarse", [0, 2, 3])
def test_iso_hits_hide_the_wireframe_behind_them_while_moving_too(viewer, coarse):
    """Iso rays at the outer ball's level with the inner ball's surface drawn too, its wireframe on: the lines
    lie behind the iso hits, so the picture is the one without the wireframe, at rest and in the moving
    view's stretched frames (their depth goes with them, and only theirs); the lines show where no ray hits."""
    data = nested()
    viewer.show_levels(as_volume(data), [0.2, 0.7])
    viewer.state.levels.set_visible(0, False)   # the rays' level: drawn by the rays alone
    viewer.state.set_with_surfaces(True)
    viewer.state.style.show_box = False

    def drawn(wireframe, level=0.2):
        viewer.state.style.wireframe = wireframe
        picture(viewer, "iso", level)
        viewer.target.use()
        viewer.app.renderer.draw_scene(viewer.scene, viewer.camera, viewer.target.viewport, coarse=coarse)
        return viewer.target.read_rgb().astype(int)
    plain, lined = drawn(False), drawn(True)
    assert np.abs(lined - plain).max() <= 1, np.count_nonzero(np.abs(lined - plain).max(axis=2) > 1)
    # rays at a level over every value: no hit, so nothing hides the lines (nor may the stretched depth)
    seen = np.abs(drawn(True, 2.0) - drawn(False, 2.0)).max(axis=2)
    assert np.count_nonzero(seen > 20) > 200


@pytest.mark.parametrize("coarse", [0, 2])
def test_wireframe_lines_are_drawn_over_the_rays_and_end_none(viewer, monkeypatch, coarse):
    """A translucent shell (0.4) with its wireframe over a MIP of a smooth cone seen from above, a slice at the
    bottom of the box (so the opaque scene's depth ends the rays, behind the cone): lines drawn with no opacity
    leave the picture as it is without them (their depth ended the rays at the shell once: the MIP behind every
    line was cut), and with theirs they darken it over the volume (drawn after the rays), nowhere lighten it.
    The same while the view moves."""
    import isoscope.viewer.gfx.renderer as renderer
    x, y, z = _grid(24)
    cone = np.clip(1.2 - 1.5 * np.sqrt(x * x + y * y + z * z), 0.0, 1.0).astype(np.float32)
    viewer.show_levels(as_volume(cone), [0.2], opacities=[0.4], azimuth=0.0, elevation=90.0)
    viewer.state.style.show_box = False
    viewer.state.set_with_surfaces(True)
    viewer.state.slices.inset = False
    viewer.state.slices.show(2, True, 0)
    inside = _inner(np.abs(picture(viewer, None) - BACKGROUND).max(axis=2) > 30, 3)

    def drawn(wireframe):
        viewer.state.style.wireframe = wireframe
        picture(viewer, "mip")
        viewer.target.use()
        viewer.app.renderer.draw_scene(viewer.scene, viewer.camera, viewer.target.viewport, coarse=coarse)
        return viewer.target.read_rgb().astype(int)
    plain, lined = drawn(False), drawn(True)
    monkeypatch.setattr(renderer, "WIRE_OPACITY", 0.0)
    unseen = drawn(True)
    assert np.abs(unseen - plain).max() <= 1, np.abs(unseen - plain).max()
    darker = (plain - lined).sum(axis=2)[inside]
    assert (darker > 45).sum() > 0.2 * inside.sum() and inside.sum() > 1000, ((darker > 45).sum(), inside.sum())
    assert darker.min() >= -3


def test_translucent_surfaces_blend_over_the_volume_and_every_entry_draws_the_same(tmp_path):
    """DVR with the core's surface (0.7) opaque and the dim ball's (0.2) at opacity 0.4 over it: the command,
    isoscope.render and the saved scene draw the same picture; the translucent shell tints the volume (the
    picture differs from the one with the core alone), and the surfaces change the picture of the volume."""
    np.save(tmp_path / "nested.npy", nested())
    options = ("--size", "200x150", "--slice", "z=8")   # the window: the default percentiles, as in Python
    done = isoscope_here("render", tmp_path / "nested.npy", "--raycast", "dvr", "--with-surfaces", "--iso", "0.7",
                         "--iso", "0.2", "--opacity", "1,0.4", *options, "--out", tmp_path / "cli.png",
                         "--save-scene", tmp_path / "s.json")
    assert done.returncode == 0, done.stderr
    assert json.loads((tmp_path / "s.json").read_text())["with_surfaces"] is True
    again = isoscope_here("render", tmp_path / "s.json", "--out", tmp_path / "scene.png")
    assert again.returncode == 0, again.stderr
    cli = np.asarray(Image.open(tmp_path / "cli.png")).astype(int)
    assert np.array_equal(cli, np.asarray(Image.open(tmp_path / "scene.png")))

    def api(levels, opacities, with_surfaces=True):
        return isoscope.render(nested(), levels, size=(200, 150), raycast="dvr", with_surfaces=with_surfaces,
                               opacities=opacities, slices=[("z", 8)])[..., :3].astype(int)
    assert np.abs(api([0.7, 0.2], [1.0, 0.4]) - cli).max() <= 1
    core_only = api([0.7], [1.0])
    assert np.abs(core_only - cli).max() > 30
    assert np.abs(api([0.7], [1.0], with_surfaces=False) - core_only).max() > 30


@pytest.mark.parametrize("spacing", [3, 4, 5])
def test_sparser_rays_while_moving_are_still_the_full_picture_stretched(viewer, spacing):
    """A ray per 3x3, 4x4 or 5x5 pixels (the window's spacing when 2x2 frames are slow): the picture to within its
    wider blur, the background untouched outside the box."""
    viewer.show(as_volume(nested()), 0.2)
    full = picture(viewer, "mip")
    viewer.target.use()
    viewer.app.renderer.draw_scene(viewer.scene, viewer.camera, viewer.target.viewport, coarse=spacing)
    coarse = viewer.target.read_rgb().astype(int)
    assert np.abs(coarse - full).mean() < 2 * spacing, np.abs(coarse - full).mean()
    assert (coarse[0, 0] == BACKGROUND).all() and (coarse[-1, -1] == BACKGROUND).all()
    assert white(coarse) > (0.5 if spacing < 5 else 0.4) * white(full) > 50   # 5x5 blurs more of the core


def test_the_window_spaces_its_moving_rays_by_the_frames_measured(gl_ctx):
    """With previews (the window), a moving ray-cast frame that took longer than the target makes the next ones
    sparser, up to 5x5 pixels a ray; fast ones make them finer again; frames at rest or without rays count for
    nothing."""
    from isoscope.viewer.model.raycast import MAX_RAY_SPACING, MIN_RAY_SPACING, MOVING_TARGET_MS
    viewer = HeadlessViewer(SIZE, ctx=gl_ctx, previews=True)
    try:
        viewer.show(as_volume(nested()), 0.2)
        app, viewport = viewer.app, viewer.target.viewport
        viewer.target.use()
        app.draw(viewport, moving=True)                 # no rays: nothing to record
        app.follow(10 * MOVING_TARGET_MS / 1000)
        assert app.rays.spacing == MIN_RAY_SPACING
        viewer.state.set_raycast("mip")
        spacings = []
        for seconds in (0.3, 0.3, 0.3, 0.07, 0.04, 0.04):
            app.draw(viewport, moving=True)
            app.follow(seconds)
            spacings.append(app.rays.spacing)
        # 70 ms at 5x5 would take 109 at 4x4: it stays; 40 ms would take 62 at 4x4, then 40 at 4x4 71 at 3x3
        assert spacings == [3, 4, MAX_RAY_SPACING, MAX_RAY_SPACING, 4, 3] and MAX_RAY_SPACING == 5, spacings
        app.draw(viewport)                              # at rest: a ray a pixel, not recorded
        app.follow(1.0)
        assert app.rays.spacing == 3
    finally:
        viewer.release()

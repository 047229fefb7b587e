"""The scene as pixels: headless EGL renders of real extractions, checked on the images."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from isoscope.viewer.headless import HeadlessViewer
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
    small_triangles = viewer.state.n_triangles
    viewer.state.set_iso(0.2)   # radius 0.5 -> 0.9: the mesh grows, the extractor may reallocate
    large = surface_mask(viewer.render(), viewer.state.style.background).sum()
    assert viewer.state.n_triangles > 2 * small_triangles
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

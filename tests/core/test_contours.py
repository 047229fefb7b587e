"""isoscope.find_contours: marching squares against scikit-image and against facts of its own."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.ndimage import gaussian_filter
from skimage import measure

import isoscope
from isoscope.core.layout import EDGE_MARGIN
from isoscope.cpu.cubes import marching_cubes_reference

OPTIONS = [(fc, po) for fc in ("low", "high") for po in ("low", "high")]


def smooth_noise(shape, seed):
    return gaussian_filter(np.random.default_rng(seed).normal(size=shape), 2.0)


def directed_segments(contours):
    """Every step of every contour as ((row, col), (row, col)), rounded far below the 1e-6 asked."""
    return {(tuple(np.round(a, 9)), tuple(np.round(b, 9))) for c in contours for a, b in zip(c[:-1], c[1:])}


def on_border(point, shape):
    r, c = point
    return min(r, c) == 0 or r == shape[0] - 1 or c == shape[1] - 1


@pytest.mark.parametrize("fully_connected, positive_orientation", OPTIONS)
@pytest.mark.parametrize("seed, shape", [(0, (40, 50)), (1, (17, 90)), (2, (64, 64))])
def test_same_curves_as_scikit_image_on_smooth_noise(seed, shape, fully_connected, positive_orientation):
    image = smooth_noise(shape, seed)
    ours = isoscope.find_contours(image, 0.0, fully_connected, positive_orientation)
    theirs = measure.find_contours(image, 0.0, fully_connected, positive_orientation)
    assert len(ours) == len(theirs) > 3
    # The same directed segments: the same points (to 1e-9), the same saddle splits, the same
    # orientation; only where each closed curve starts may differ.
    assert directed_segments(ours) == directed_segments(theirs)
    assert sorted(len(c) for c in ours) == sorted(len(c) for c in theirs)


def test_mask_keeps_only_squares_with_four_true_corners_as_scikit_image():
    image = smooth_noise((50, 50), 3)
    mask = np.ones(image.shape, bool)
    mask[10:30, 20:25] = False
    mask[np.random.default_rng(4).random(image.shape) < 0.02] = False
    ours = isoscope.find_contours(image, 0.0, mask=mask)
    assert directed_segments(ours) == directed_segments(measure.find_contours(image, 0.0, mask=mask))
    assert directed_segments(ours) != directed_segments(isoscope.find_contours(image, 0.0))


def test_default_level_is_mid_range():
    image = smooth_noise((30, 30), 5)
    mid = (image.min() + image.max()) / 2
    assert directed_segments(isoscope.find_contours(image)) == directed_segments(isoscope.find_contours(image, mid))


def signed_area(contour):
    """Shoelace area with columns as x and rows pointing down (an image on screen): > 0 counter-clockwise."""
    x, y = contour[:, 1], -contour[:, 0]
    return 0.5 * float(np.sum(x[:-1] * y[1:] - x[1:] * y[:-1]))


def test_low_islands_are_wound_counter_clockwise_and_high_ones_clockwise():
    r, c = np.mgrid[:41, :41]
    dip = np.hypot(r - 20, c - 20) - 10.5          # low inside a circle of radius 10.5
    (low_island,) = isoscope.find_contours(dip, 0.0)
    (flipped,) = isoscope.find_contours(dip, 0.0, positive_orientation="high")
    assert signed_area(low_island) == pytest.approx(np.pi * 10.5**2, rel=0.01)
    assert signed_area(flipped) == pytest.approx(-np.pi * 10.5**2, rel=0.01)
    (high_island,) = isoscope.find_contours(-dip, 0.0)
    assert signed_area(high_island) < 0


def test_saddle_squares_join_the_side_that_is_fully_connected():
    checker = np.array([[1.0, 0.0], [0.0, 1.0]])   # high corners on the main diagonal
    low = isoscope.find_contours(checker, 0.5, fully_connected="low")
    high = isoscope.find_contours(checker, 0.5, fully_connected="high")
    assert len(low) == len(high) == 2
    # 'low': the low corners (0, 1) and (1, 0) are joined, so each curve cuts off one high corner;
    # 'high': the high corners are joined and each curve cuts off a low one.
    assert sorted(np.round(np.mean(c, axis=0), 2).tolist() for c in low) == [[0.25, 0.25], [0.75, 0.75]]
    assert sorted(np.round(np.mean(c, axis=0), 2).tolist() for c in high) == [[0.25, 0.75], [0.75, 0.25]]


def check_clean_curves(contours, shape):
    """Closed or border to border; no vertex repeated, on a grid point, or shared by two curves;
    every vertex in two segments but the open ends."""
    seen = set()
    for contour in contours:
        closed = np.array_equal(contour[0], contour[-1])
        body = contour[:-1] if closed else contour
        keys = {tuple(np.round(p, 9)) for p in body}
        assert len(keys) == len(body), "a vertex repeats within a curve"
        assert not keys & seen, "two curves share a vertex"
        seen |= keys
        assert not np.any(np.all(np.abs(body - np.round(body)) < 1e-12, axis=1)), "a vertex on a grid point"
        if not closed:
            assert on_border(contour[0], shape) and on_border(contour[-1], shape)
    return seen


@pytest.mark.parametrize("image", [
    np.add.outer(np.arange(30.0), 2 * np.arange(25.0)) - 20,          # r + 2c - 20: a line through samples
    np.pad(np.ones((10, 12)), 6),                                     # a plateau whose border is the level
    np.round(smooth_noise((40, 40), 6), 1),                           # many samples exactly at 0
], ids=["integer-line", "plateau", "rounded-noise"])
def test_exact_ties_give_clean_curves(image):
    level = 1.0 if image.max() == 1.0 else 0.0
    assert np.count_nonzero(image == level) >= 10
    contours = isoscope.find_contours(image, level)
    assert contours
    vertices = check_clean_curves(contours, image.shape)
    # Vertices moved off tied samples sit EDGE_MARGIN along their edge from them.
    offsets = np.array([abs(v - round(v)) for p in vertices for v in p if abs(v - round(v)) > 0])
    assert offsets.min() >= EDGE_MARGIN - 1e-12


def test_the_isocurve_of_a_slice_lies_on_the_3d_mesh_cut_by_that_plane():
    volume = gaussian_filter(np.random.default_rng(7).normal(size=(20, 24, 28)), 2.0).astype(np.float32)
    verts, _, _, _ = marching_cubes_reference(volume, 0.0)
    for index in (0, 7, 19):
        curve_points = np.concatenate(isoscope.find_contours(volume[index].astype(np.float64), 0.0))
        in_plane = verts[verts[:, 0] == index][:, 1:]     # mesh vertices on edges inside the plane
        ours = {tuple(np.round(p, 4)) for p in curve_points}
        assert len(ours) == len(in_plane)
        # Each curve vertex is a mesh vertex: equal but for the mesh's float32 positions and its
        # EDGE_MARGIN clamp near samples.
        distance = np.abs(curve_points[:, None, :] - in_plane[None, :, :]).max(axis=2).min(axis=1)
        assert distance.max() <= EDGE_MARGIN + 1e-5


@pytest.mark.parametrize("args, kwargs, words", [
    ((np.zeros((3, 3, 3)), 0.0), {}, "2-D"),
    ((np.zeros((1, 5)), 0.0), {}, "shorter than 2"),
    ((np.zeros((4, 4)), 0.0), {"fully_connected": "mid"}, "fully_connected"),
    ((np.zeros((4, 4)), 0.0), {"positive_orientation": 1}, "positive_orientation"),
    ((np.zeros((4, 4)), 0.0), {"mask": np.ones((4, 5), bool)}, "mask"),
])
def test_bad_arguments_are_one_line_value_errors(args, kwargs, words):
    with pytest.raises(ValueError) as err:
        isoscope.find_contours(*args, **kwargs)
    assert words in str(err.value) and "\n" not in str(err.value)


def test_nan_samples_are_left_out_as_scikit_image_does():
    image = smooth_noise((40, 40), 8)
    image[5:12, 5:30] = np.nan
    ours = isoscope.find_contours(image, 0.0)
    assert directed_segments(ours) == directed_segments(measure.find_contours(image, 0.0))
    assert not any(np.isnan(c).any() for c in ours)

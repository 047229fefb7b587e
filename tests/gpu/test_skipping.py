"""Empty-space skipping changes no triangle: the resident extractor equals a full extraction."""
import numpy as np
import pytest

from isoscope.cpu.cubes import BRICK_I, BRICK_J, marching_cubes_reference
from isoscope.gpu.cubes import Extractor


def brick_ranges(ex):
    """The (min, max) the extractor measured for each brick."""
    return np.frombuffer(ex.resident.brick_ranges.read(), np.float32).reshape(-1, 2)[: ex.brick_count]


def independent_brick_ranges(volume):
    """Each brick's range from numpy: its 8 x 8 rows x 32 samples plus one more along each axis."""
    n0, n1, n2 = volume.shape
    out = []
    for i in range(0, n0, BRICK_I):
        for j in range(0, n1, BRICK_J):
            for k in range(0, n2, 32):
                block = volume[i : i + BRICK_I + 1, j : j + BRICK_J + 1, k : k + 33]
                out.append((block.min(), block.max()))
    return np.array(out, np.float32)


@pytest.fixture(scope="module")
def blobs():
    """Separate blobs in an empty field: most bricks are skipped at most levels."""
    rng = np.random.default_rng(7)
    shape = (37, 29, 70)  # partial bricks on every axis
    grid = np.stack(np.meshgrid(*[np.arange(n, dtype=np.float32) for n in shape], indexing="ij"))
    field = np.zeros(shape, np.float32)
    for _ in range(6):
        centre = rng.uniform(0, shape).astype(np.float32)[:, None, None, None]
        field += np.exp(-((grid - centre) ** 2).sum(0) / rng.uniform(4, 30))
    return np.round(field, 3)  # rounding puts many samples exactly on brick minima and maxima


def test_brick_ranges_cover_every_sample_a_brick_touches(gl_ctx, blobs):
    with Extractor(blobs, ctx=gl_ctx) as ex:
        np.testing.assert_array_equal(brick_ranges(ex), independent_brick_ranges(blobs))


@pytest.mark.parametrize("direction", ["descent", "ascent"])
def test_resident_extraction_equals_full_extraction_at_brick_bounds(gl_ctx, blobs, direction):
    with Extractor(blobs, ctx=gl_ctx, gradient_direction=direction) as ex:
        ranges = brick_ranges(ex)
        lo, hi = ex.value_range
        candidates = np.unique(np.concatenate([ranges.ravel(), np.linspace(lo, hi, 9)]))
        levels = np.random.default_rng(1).choice(candidates, size=24, replace=False)
        skipped_somewhere = False
        for level in levels:  # one resident volume, many iso changes in a row
            ex.extract(float(level))
            verts, faces, normals, _ = ex.read_mesh()
            ref_verts, ref_faces, ref_normals, _ = marching_cubes_reference(
                blobs, float(level), descent=direction == "descent")
            np.testing.assert_array_equal(faces, ref_faces)
            np.testing.assert_allclose(verts, ref_verts, atol=1e-5)
            np.testing.assert_allclose(normals, ref_normals, atol=1e-5)
            skipped_somewhere |= 0 < ex.active_bricks < ex.brick_count
        assert skipped_somewhere  # the test exercised skipping, not only all-active bricks


def inside_words(volume, level, descent=True):
    """Independently: the packed inside bits of every row word, (n0, n1, words) uint32, ties inside."""
    inside = volume >= level if descent else volume <= level
    n0, n1, n2 = volume.shape
    words = -(-n2 // 32)
    padded = np.zeros((n0, n1, words * 32), bool)
    padded[:, :, :n2] = inside
    weights = (1 << np.arange(32, dtype=np.uint64))
    return (padded.reshape(n0, n1, words, 32) * weights).sum(-1).astype(np.uint32)


def sign_words(ex):
    """The extractor's sign-word image, word by word in grid order."""
    n0, n1, n2 = ex.shape
    count = n0 * n1 * -(-n2 // 32)
    return np.frombuffer(ex.scratch.sign_words.read(), np.uint32)[:count].reshape(n0, n1, -1)


@pytest.mark.parametrize("direction", ["descent", "ascent"])
def test_every_sign_word_is_right_after_bricks_change_sides(gl_ctx, blobs, direction):
    """Skipped bricks keep their constant sign words from one extraction to the next and write them
    only when they change side (mc_bricks.comp's brick states): after each level of a sequence that
    repeats levels, jumps a brick straight from one side to the other and back, and takes in a new
    volume of the same shape, every word, skipped or not, holds the volume's inside bits."""
    descent = direction == "descent"
    lo, hi = float(blobs.min()), float(blobs.max())
    other = np.ascontiguousarray(blobs[::-1, :, ::-1])  # the same shape and range, other bricks busy
    with Extractor(blobs, ctx=gl_ctx, gradient_direction=direction) as ex:
        current = blobs
        for volume, level in [(blobs, 0.5), (blobs, 0.5), (blobs, hi), (blobs, lo), (blobs, hi), (blobs, 0.3),
                              (other, 0.3), (other, lo), (other, 0.6), (blobs, 0.6)]:
            if volume is not current:
                ex.reload(volume, gradient_direction=direction)
                current = volume
            ex.extract(level)
            np.testing.assert_array_equal(sign_words(ex), inside_words(volume, level, descent))
            ref_verts, ref_faces, _, _ = marching_cubes_reference(volume, level, descent=descent)
            verts, faces, _, _ = ex.read_mesh()
            np.testing.assert_array_equal(faces, ref_faces)
            np.testing.assert_allclose(verts, ref_verts, atol=1e-5)

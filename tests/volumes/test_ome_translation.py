"""An OME-Zarr image's "translation" coordinate transformations: the full level's is the image's world origin
(export --space world, measure), each coarser level's, less the full level's, is where its samples lie (a
pyramid of block means: their blocks' centres, (f - 1) / 2 full samples in), which the viewer's coarse view
of that level keeps (big_volume.from_level: its `origin`).  A translation that is not one finite number per
axis is refused in one line.  The stores are written by the zarr library; meshes are read back by trimesh."""
from __future__ import annotations

import functools
import json

import numpy as np
import pytest
import trimesh
import zarr
from support.command import assert_one_line_error, isoscope_here, succeeded_here
from support.ome_zarr import half_block_translations, mean_levels, with_translations, write_ome

import isoscope
from isoscope.errors import IsoscopeError
from isoscope.io.export import in_volume_space
from isoscope.viewer.model.big_volume import from_level
from isoscope.volumes import open_volume

N = 40
CENTRE = (19.3, 20.6, 18.9)   # samples, off the grid and off the centre: a shift cannot hide in symmetry
RADIUS = 12.0
LEVEL = 0.0
SHIFT = [100.0, 20.5, -3.0]   # (z, y, x): a microscopy tile placed in the scan's coordinates


@pytest.fixture(scope="module")
def ball():
    """A ball's signed distance (inside positive), float32, N^3 samples."""
    grid = np.indices((N, N, N), dtype=np.float64)
    distance = np.sqrt(sum((g - c) ** 2 for g, c in zip(grid, CENTRE)))
    return (RADIUS - distance).astype(np.float32)


def centre_of(verts) -> np.ndarray:
    """The centre of the sphere through `verts` (least squares: |v|^2 = 2 c.v + r^2 - |c|^2)."""
    verts = np.asarray(verts, np.float64)
    a = np.column_stack([2 * verts, np.ones(len(verts))])
    solution, *_ = np.linalg.lstsq(a, (verts ** 2).sum(axis=1), rcond=None)
    return solution[:3]


def centre_in_samples(verts, moved, spacing) -> np.ndarray:
    """`centre_of` in full samples, where the ball is round: `verts` less `moved`, over `spacing`."""
    return centre_of((np.asarray(verts, np.float64) - moved) / spacing)


@pytest.mark.parametrize("zarr_format", [2, 3])
def test_the_full_level_s_translation_is_the_world_origin_of_export(tmp_path, ball, zarr_format):
    spacing = (0.5, 0.25, 0.75)
    write_ome(tmp_path / "plain.ome.zarr", [ball], [spacing], zarr_format=zarr_format)
    moved = tmp_path / "moved.ome.zarr"
    write_ome(moved, [ball], [spacing], zarr_format=zarr_format)
    with_translations(moved, [SHIFT])
    meshes = {}
    for name, path in (("plain", tmp_path / "plain.ome.zarr"), ("moved", moved)):
        for space in ("world", "voxel"):
            out = tmp_path / f"{name}-{space}.ply"
            done = succeeded_here("export", str(path), "--iso", str(LEVEL), "--out", str(out), "--space", space)
            meshes[name, space] = trimesh.load(out, process=False).vertices
            assert f"in {'OME-Zarr' if (name, space) == ('moved', 'world') else 'index x spacing'} coordinates" \
                   in done.stdout
    assert len(meshes["plain", "world"]) > 1000
    np.testing.assert_array_equal(meshes["plain", "voxel"], meshes["moved", "voxel"])   # voxel space as before
    np.testing.assert_array_equal(meshes["plain", "world"], meshes["plain", "voxel"])   # no translation: no frame
    np.testing.assert_allclose(meshes["moved", "world"] - meshes["plain", "world"],
                               np.broadcast_to(SHIFT, meshes["plain", "world"].shape), atol=2e-5)
    volume = open_volume(str(moved))
    assert volume.world[1] == "OME-Zarr" and np.allclose(volume.world[0][:3, :3], np.diag(spacing))
    np.testing.assert_allclose(centre_of((meshes["moved", "world"] - SHIFT) / spacing), CENTRE, atol=0.02)


def test_measure_reports_the_bounding_box_in_the_translated_frame(tmp_path, ball):
    write_ome(tmp_path / "m.ome.zarr", [ball], [(1.0, 1.0, 1.0)])
    path = with_translations(tmp_path / "m.ome.zarr", [SHIFT])
    world = json.loads(succeeded_here("measure", str(path), "--iso", str(LEVEL), "--json").stdout)
    voxel = json.loads(succeeded_here("measure", str(path), "--iso", str(LEVEL), "--json", "--space", "voxel").stdout)
    (w,), (v,) = world, voxel
    np.testing.assert_allclose(np.subtract(w["bbox_min"], v["bbox_min"]), SHIFT, atol=1e-4)
    np.testing.assert_allclose(w["area_mm2"], v["area_mm2"], rtol=1e-6)


def test_the_image_s_own_transformations_apply_after_the_level_s(tmp_path, ball):
    """NGFF: the multiscale's coordinateTransformations come after each dataset's, so its scale scales the
    dataset's translation: x = s_image (s_level i + t_level) + t_image."""
    path = tmp_path / "i.ome.zarr"
    write_ome(path, [ball], [(0.5, 0.5, 0.5)])
    image = [{"type": "scale", "scale": [2.0, 3.0, 4.0]}, {"type": "translation", "translation": [1.0, -1.0, 0.5]}]
    with_translations(path, [[10.0, 20.0, 30.0]], image=image)
    volume = open_volume(str(path))
    matrix = volume.world[0]
    index = np.array([3.0, 5.0, 7.0])
    expected = np.array([2.0, 3.0, 4.0]) * (0.5 * index + [10.0, 20.0, 30.0]) + [1.0, -1.0, 0.5]
    np.testing.assert_allclose((matrix @ [*index, 1.0])[:3], expected)
    assert volume.spacing == (1.0, 1.5, 2.0)


def test_without_a_translation_nothing_changes(tmp_path, ball):
    levels = mean_levels(ball, 2)
    write_ome(tmp_path / "p.ome.zarr", levels, [(1.0,) * 3, (2.0,) * 3])
    volume = open_volume(str(tmp_path / "p.ome.zarr"))
    assert volume.world is None and volume.pyramid[0].offset == (0.0, 0.0, 0.0)
    shown, step = from_level(volume, volume.pyramid[0])
    assert shown.origin == (0.0, 0.0, 0.0) and shown.world is None and step == 2


@pytest.mark.parametrize("shift", [None, SHIFT])
def test_a_mean_pyramid_s_coarse_view_lies_on_the_full_level_s_surface(tmp_path, ball, shift):
    """Levels of 2^3 and 4^3 block means with translations (f - 1) / 2 x the full spacing (as ome-zarr-py writes
    them): each level's PyramidLevel.offset is (f - 1) / 2 samples, and the viewer's coarse view of it (its mesh
    placed by its origin, in index x spacing and, with a world frame, in world) has the full level's sphere
    centre within a tenth of a full sample; without the offset it would be (f - 1) / 2 samples off."""
    spacing = np.array([0.5, 0.4, 0.3])
    path = tmp_path / "pyramid.ome.zarr"
    write_ome(path, mean_levels(ball, 3), [tuple(spacing * 2 ** k) for k in range(3)])
    half_blocks = half_block_translations(3, spacing)
    with_translations(path, [[a + b for a, b in zip(shift or (0, 0, 0), t)] for t in half_blocks])
    volume = open_volume(str(path))
    np.testing.assert_allclose([level.offset for level in volume.pyramid], [(0.5,) * 3, (1.5,) * 3], rtol=1e-12)
    full = isoscope.api.outward_marching_cubes(np.asarray(volume.data), LEVEL, spacing=volume.spacing,
                                               backend="cpu")
    for space in ("voxel", "world"):
        moved = np.asarray(shift if space == "world" and shift else (0.0, 0.0, 0.0))
        centre = functools.partial(centre_in_samples, moved=moved, spacing=spacing)
        expected = centre(in_volume_space(volume, *full[:3], world=space == "world")[0])
        np.testing.assert_allclose(expected, CENTRE, atol=0.02)
        for level, factor in zip(volume.pyramid, (2, 4)):
            shown, step = from_level(volume, level)
            assert step == factor
            verts, faces, normals, _ = isoscope.api.outward_marching_cubes(shown.data, LEVEL, spacing=shown.spacing,
                                                                           backend="cpu")
            placed = centre(in_volume_space(shown, verts, faces, normals, world=space == "world")[0])
            assert np.all(np.abs(placed - expected) < 0.1), (level.name, space, placed - expected)
            assert np.all(np.abs(centre(verts + moved) - expected - (1 - factor) / 2) < 0.1)   # unplaced: off


@pytest.mark.parametrize(("where", "translation", "words"), [
    ("0", [1.0, 2.0], "OME-Zarr level '0' has translation [1.0, 2.0] in its coordinateTransformations, not a list "
                      "of 3 finite numbers (one per axis); write it again with one number per axis"),
    ("0", [1.0, "a", 3.0], "OME-Zarr level '0' has translation [1.0, 'a', 3.0]"),
    ("1", [0.5, float("nan"), 0.5], "OME-Zarr level '1' has translation [0.5, nan, 0.5]"),
    ("1", "0.5", "OME-Zarr level '1' has translation '0.5'"),
    ("image", [0.0, 0.0, None], "OME-Zarr level '0' has translation [0.0, 0.0, None] in the image's "
                                "coordinateTransformations"),
])
def test_a_translation_that_is_not_one_finite_number_per_axis_is_refused_in_one_line(tmp_path, ball, where,
                                                                                      translation, words):
    path = tmp_path / "bad.ome.zarr"
    write_ome(path, mean_levels(ball, 2), [(1.0,) * 3, (2.0,) * 3])
    if where == "image":
        with_translations(path, [], image=[{"type": "translation", "translation": translation}])
    else:
        with_translations(path, [translation if where == "0" else None, translation if where == "1" else None])
    with pytest.raises(IsoscopeError) as caught:
        open_volume(str(path))
    assert words in str(caught.value) and "\n" not in str(caught.value)
    assert_one_line_error(isoscope_here("export", str(path), "--out", str(tmp_path / "m.ply")), words)


@pytest.mark.parametrize(("translations", "left_out"), [
    ([None, [0.5, 2.5, 0.5]], "OME-Zarr level '1' left out: its translation (0.5x2.5x0.5, scale 2x2x2) puts its "
                              "sample 0 0.5x2.5x0.5 samples of level '0' from that level's (translation 0x0x0), "
                              "more than one of its own (2x2x2); far.ome.zarr would show it in the wrong place"),
    ([[10.0, 10.0, 10.0], [10.0, 10.0, 7.5]], "puts its sample 0 0x0x-2.5 samples of level '0'"),
    ([[1000.0, 20.0, 5.0], None], "OME-Zarr level '1' left out"),   # a stage position on the full level alone
    ([None, [2.0, -2.0, 0.0]], None),                  # one of its own samples off: taken (its offset)
    ([[1.0, 1.0, 1.0], [1.5, 1.5, 1.5]], None),        # a pyramid of means, moved
])
def test_a_coarser_level_more_than_one_of_its_samples_from_its_place_is_left_out_with_a_note(tmp_path, ball,
                                                                                             translations, left_out):
    """A coarser level's translation, less the full level's, puts its sample 0 within one of its own samples of
    the full level's sample 0 (|offset| <= its spacing over the full level's, per axis: block means are half a
    block in); further, the level would be shown in the wrong place: it is left out, with a note, and the full
    level opens whole (refusing the file would shut out a store whose writer placed only the full level)."""
    path = tmp_path / "far.ome.zarr"
    write_ome(path, mean_levels(ball, 2), [(1.0,) * 3, (2.0,) * 3])
    with_translations(path, translations)
    volume = open_volume(str(path))
    if left_out is None:
        expected = np.subtract(translations[1], translations[0] or (0.0,) * 3)
        np.testing.assert_allclose(volume.pyramid[0].offset, expected)
        return
    assert volume.pyramid == () and any(left_out in note for note in volume.notes), volume.notes
    np.testing.assert_array_equal(np.asarray(volume.data), ball)


def test_a_translation_its_scale_makes_infinite_is_refused_in_one_line(tmp_path, ball):
    """The image's scale multiplies the levels' translations: where that overflows, the world frame and the
    levels' offsets would be infinite; one line instead."""
    path = tmp_path / "inf.ome.zarr"
    write_ome(path, mean_levels(ball, 2), [(1.0,) * 3, (2.0,) * 3])
    with_translations(path, [[1e10, 1.0, 1e10], [1e10, 1.0, 1e10]], image=[{"type": "scale", "scale": [1e300] * 3}])
    words = ("OME-Zarr level '0' has a translation its scale makes infx1e+300xinf, not finite; write it again with "
             "numbers whose product is finite")
    with pytest.raises(IsoscopeError) as caught:
        open_volume(str(path))
    assert words in str(caught.value) and "\n" not in str(caught.value)
    assert_one_line_error(isoscope_here("export", str(path), "--out", str(tmp_path / "m.ply")), words)


def _transformed(path, level: int, transform=None, image=None):
    """The store at `path` with `transform` in place of level `level`'s scale (None: kept), and `image` as the
    multiscale's own coordinateTransformations."""
    group = zarr.open_group(str(path), mode="r+")
    multiscales = group.attrs["multiscales"]
    if transform is not None:
        multiscales[0]["datasets"][level]["coordinateTransformations"][0] = transform
    if image is not None:
        multiscales[0]["coordinateTransformations"] = image
    group.attrs["multiscales"] = multiscales
    return path


@pytest.mark.parametrize(("level", "transform", "image", "words"), [
    (0, {"type": "translation", "path": "translation.bin"}, None,
     "OME-Zarr level '0' has its translation in a file ('translation.bin') in its coordinateTransformations; "
     "isoscope reads only inline transformations: write it again with the translation's numbers in the metadata"),
    (1, {"type": "scale", "path": "scale.bin"}, None, "OME-Zarr level '1' has its scale in a file ('scale.bin')"),
    (0, None, [{"type": "translation", "path": "t.bin"}],
     "OME-Zarr level '0' has its translation in a file ('t.bin') in the image's coordinateTransformations"),
    (0, {"type": "scale", "scale": [1.0, 1.0]}, None,
     "OME-Zarr level '0' has scale [1.0, 1.0] in its coordinateTransformations, not a list of 3 finite numbers "
     "(one per axis); write it again with one number per axis"),
    (1, {"type": "scale", "scale": [1, 2.0, 2.0, 2.0]}, None,
     "OME-Zarr level '1' has scale [1, 2.0, 2.0, 2.0] in its coordinateTransformations, not a list of 3"),
])
def test_a_transformation_in_a_file_or_a_scale_not_one_number_per_axis_is_refused_in_one_line(
        tmp_path, ball, level, transform, image, words):
    """isoscope reads the coordinateTransformations written in the metadata, not those stored in a file ("path"),
    and says so (it said "translation None"); a scale of another length than the axes is refused as a
    translation is (it was passed over)."""
    path = tmp_path / "t.ome.zarr"
    write_ome(path, mean_levels(ball, 2), [(1.0,) * 3, (2.0,) * 3])
    _transformed(path, level, transform, image)
    with pytest.raises(IsoscopeError) as caught:
        open_volume(str(path))
    assert words in str(caught.value) and "\n" not in str(caught.value)
    assert_one_line_error(isoscope_here("export", str(path), "--out", str(tmp_path / "m.ply")), words)

"""An OME-Zarr image's pyramid checked at open (issue 33, point 4 and "bad input"): each lower-resolution level
is smaller than the one before it and its scale matches how many fewer samples it has; a level the metadata
names must be in the store.  Each refusal is one line naming the level and the fix (exit 2 on the command
line).  The stores are written by the zarr library."""
from __future__ import annotations

import re

import numpy as np
import pytest
import zarr
from support.command import assert_one_line_error, isoscope_here
from support.ome_zarr import write_ome

from isoscope.errors import IsoscopeError
from isoscope.viewer.model.bricks import level_factor
from isoscope.volumes import open_volume


def write_pyramid(path, shapes, scales, missing=(), zarr_format=2):
    """An OME-Zarr image whose level i has `shapes[i]` (z, y, x) samples and scale `scales[i]` (as many values
    as axes); the levels in `missing` are named in the metadata but not written."""
    rng = np.random.default_rng(5)
    levels = [None if i in missing else rng.random(shape, "f4") for i, shape in enumerate(shapes)]
    write_ome(path, levels, scales, zarr_format=zarr_format, missing=missing)
    return path


@pytest.mark.parametrize("zarr_format", [2, 3])
def test_a_sound_pyramid_opens_with_its_levels_and_their_whole_factors(tmp_path, zarr_format):
    path = write_pyramid(tmp_path / "ok.ome.zarr", [(24, 24, 24), (12, 12, 12), (6, 6, 6)],
                         [(0.5,) * 3, (1.0,) * 3, (2.0,) * 3], zarr_format=zarr_format)
    volume = open_volume(str(path))
    assert [level.name for level in volume.pyramid] == ["1", "2"]
    assert [level_factor(volume, level) for level in volume.pyramid] == [2, 4]


def test_a_level_whose_metadata_does_not_parse_is_left_out_with_a_note(tmp_path):
    path = write_pyramid(tmp_path / "odd.ome.zarr", [(24, 24, 24), (12, 12, 12), (6, 6, 6)],
                         [(1.0,) * 3, (2.0,) * 3, (4.0,) * 3])
    group = zarr.open_group(str(path), mode="r+")
    multiscales = group.attrs["multiscales"]
    del multiscales[0]["datasets"][1]["path"]
    group.attrs["multiscales"] = multiscales
    volume = open_volume(str(path))
    assert [level.name for level in volume.pyramid] == ["2"]
    assert any(note.startswith("OME-Zarr level {") and "left out" in note for note in volume.notes)


@pytest.mark.parametrize("where", ["0", "1"])
def test_a_level_that_is_a_group_or_a_scale_that_is_no_numbers_is_one_line(tmp_path, where):
    path = write_pyramid(tmp_path / "g.ome.zarr", [(24, 24, 24), (12, 12, 12)], [(1.0,) * 3, (2.0,) * 3],
                         missing=(int(where),))
    zarr.open_group(str(path), mode="r+").create_group(where)   # a group where the level's array should be
    words = {"0": "its OME-Zarr level '0' is a group, not an array; write the level again",
             "1": "names level '1', which is not an array in the store"}[where]
    with pytest.raises(IsoscopeError, match=re.escape(words)):
        open_volume(str(path))
    path = write_pyramid(tmp_path / "s.ome.zarr", [(24, 24, 24), (12, 12, 12)], [(1.0,) * 3, (2.0,) * 3])
    group = zarr.open_group(str(path), mode="r+")
    multiscales = group.attrs["multiscales"]
    multiscales[0]["datasets"][int(where)]["coordinateTransformations"][0]["scale"] = ["a", 1, 1]
    group.attrs["multiscales"] = multiscales
    if where == "0":
        with pytest.raises(IsoscopeError, match="the scale of its OME-Zarr level '0' is not a list of numbers"):
            open_volume(str(path))
    else:   # a coarser level's metadata that does not parse: left out, said in a note
        volume = open_volume(str(path))
        assert volume.pyramid == () and any("OME-Zarr level '1' left out" in note for note in volume.notes)


def test_odd_shapes_halved_either_way_are_sound(tmp_path):
    """97 samples halved are 49 (every 2nd sample) or 48 (2x2x2 means, the last sample dropped): both agree
    with a scale of 2."""
    path = write_pyramid(tmp_path / "odd.ome.zarr", [(25, 25, 25), (13, 12, 13)], [(1.0,) * 3, (2.0,) * 3])
    volume = open_volume(str(path))
    assert level_factor(volume, volume.pyramid[0]) == 2


def test_factors_that_are_not_one_whole_number_give_no_brick_factor(tmp_path):
    """A level downsampled by 1.5, or along two axes only (a light-sheet's z kept), is sound, but no brick
    layout takes it: the viewer shows it as before, without bricks."""
    path = write_pyramid(tmp_path / "frac.ome.zarr", [(24, 24, 24), (16, 16, 16)], [(1.0,) * 3, (1.5,) * 3])
    volume = open_volume(str(path))
    assert level_factor(volume, volume.pyramid[0]) is None
    path = write_pyramid(tmp_path / "xy.ome.zarr", [(24, 24, 24), (24, 12, 12)], [(1.0,) * 3, (1.0, 2.0, 2.0)])
    volume = open_volume(str(path))
    assert [level.name for level in volume.pyramid] == ["1"] and level_factor(volume, volume.pyramid[0]) is None


@pytest.mark.parametrize(("shapes", "scales", "missing", "words"), [
    ([(24, 24, 24), (12, 12, 12), (16, 16, 16)], [(1.0,) * 3, (2.0,) * 3, (4.0,) * 3], (),
     ["level '2' (16x16x16) is larger than level '1' before it (12x12x12)", "write the pyramid again"]),
    ([(24, 24, 24), (12, 12, 12)], [(1.0,) * 3, (4.0,) * 3], (),
     ["level '1' (12x12x12, scale 4x4x4) does not match level '0'", "scale says one sample in 4x4x4",
      "its shape one in 2x2x2", "write the pyramid again"]),
    ([(24, 24, 24), (12, 12, 12)], [(1.0,) * 3, (1.0,) * 3], (),   # the scales left at 1: the level drawn half size
     ["level '1' (12x12x12, scale 1x1x1) does not match level '0'"]),
    ([(24, 24, 24), (12, 12, 12)], [(1.0,) * 3, (2.0, 2.0, -2.0)], (), ["level '1' has scale 2x2x-2, not positive"]),
    ([(24, 24, 24), (12, 12, 12), (6, 6, 6)], [(1.0,) * 3, (2.0,) * 3, (4.0,) * 3], (1,),
     ["names level '1', which is not an array in the store",
      "write the level, or drop it from the multiscales datasets"]),
    ([(24, 24, 24), (12, 12, 12)], [(-1.0, 1.0, 1.0), (2.0,) * 3], (), ["level '0' has scale -1x1x1, not positive"]),
    ([(24, 24, 24), (12, 12)], [(1.0,) * 3, (2.0,) * 2], (), ["level '1' has 2 axes and level '0' before it 3"]),
])
@pytest.mark.parametrize("zarr_format", [2, 3])
def test_a_pyramid_whose_levels_disagree_or_are_missing_is_refused_in_one_line(tmp_path, shapes, scales, missing,
                                                                                words, zarr_format):
    path = write_pyramid(tmp_path / "bad.ome.zarr", shapes, scales, missing, zarr_format)
    with pytest.raises(IsoscopeError) as caught:
        open_volume(str(path))
    message = str(caught.value)
    assert "\n" not in message and message.startswith("bad.ome.zarr: ")
    for word in words:
        assert word in message
    done = isoscope_here("export", path, "--iso", "0.5", "--out", tmp_path / "bad.ply")
    assert_one_line_error(done, *words)
    assert not (tmp_path / "bad.ply").exists()


def shown_in_bricks(volume, budget, refusal=None):
    """What the viewer shows of `volume` over `budget` (big_volume.downsampled, with the GPU's `refusal`): the
    volume on show, its step, its bricks (model/bricks.brick_view, None without) and its "a big volume" note."""
    from isoscope.viewer.model.big_volume import downsampled
    from isoscope.viewer.model.bricks import brick_view
    shown, step = downsampled(volume, budget, refusal)
    (note,) = [note for note in shown.notes if "a big volume" in note]
    return shown, step, brick_view(volume, step, budget, shown), note


@pytest.mark.parametrize(("level_shape", "scale", "bricks"), [((32, 32, 32), 2.0, True), ((43, 43, 43), 1.5, False)])
def test_over_the_budget_a_level_is_shown_in_bricks_only_where_its_factor_is_whole(tmp_path, level_shape, scale,
                                                                                   bricks):
    """The viewer's coarse view is the level either way (read whole, the file's samples); bricks refine it
    from the full level where one of its samples spans a whole number of the full level's, else the note says
    why there are none."""
    from isoscope.core.budget import MemoryBudget
    path = write_pyramid(tmp_path / "p.ome.zarr", [(64, 64, 64), level_shape], [(1.0,) * 3, (scale,) * 3])
    volume = open_volume(str(path))
    budget = MemoryBudget(1 << 20, "test")   # level 0 (64^3 float32) needs 2 MiB to show whole
    shown, step, view, note = shown_in_bricks(volume, budget)
    np.testing.assert_array_equal(shown.data, np.asarray(zarr.open_group(str(path), mode="r")["1"]))
    assert "shown from its level '1'" in note
    if bricks:
        assert step == 2 and view is not None and view.layout.step == 2
        assert "the bricks in view refined to full resolution from the full level" in note
    else:
        assert view is None
        assert "no bricks at full resolution: they need a level downsampled by one whole number along every " \
               "axis, and level '1' is 1.5x1.5x1.5" in note


@pytest.mark.parametrize(("budget", "shown"), [(2 << 20, "2"), (5 << 20, "1")])
def test_the_coarse_level_is_the_finest_that_takes_a_quarter_of_the_room_as_a_strided_view_would(tmp_path, budget,
                                                                                                  shown):
    """96^3 float32 (6.4 MiB to show whole) with levels 48^3 (0.6 MiB) and 24^3: under 2M the 48^3 level would
    fit beside a brick but take more than a quarter of the 1.5 MiB room, leaving little for the bricks' meshes,
    so the 24^3 level is the coarse view (a 4th of the room, as core/bricks.py coarse_step asks of every
    step-th sample); under 5M the 48^3 level is."""
    from isoscope.core.budget import MemoryBudget
    from isoscope.viewer.model.big_volume import downsampled
    from isoscope.viewer.model.bricks import brick_view
    path = write_pyramid(tmp_path / "p.ome.zarr", [(96, 96, 96), (48, 48, 48), (24, 24, 24)],
                         [(1.0,) * 3, (2.0,) * 3, (4.0,) * 3])
    volume = open_volume(str(path))
    memory = MemoryBudget(budget, "test")
    coarse, step = downsampled(volume, memory)
    np.testing.assert_array_equal(coarse.data, np.asarray(zarr.open_group(str(path), mode="r")[shown]))
    assert step == 2 ** int(shown) and brick_view(volume, step, memory, coarse).layout.step == step


@pytest.mark.parametrize(("coarsest", "bricks"), [((2.0, 4.0, 4.0), False), ((4.0, 4.0, 4.0), True)])
def test_under_the_gpu_s_limits_a_level_gets_bricks_only_where_they_fit_its_own_samples(tmp_path, coarsest, bricks):
    """A GPU that holds only the coarsest level: a level of whole factor gets bricks (made on the CPU, which the
    limits do not bound) and its note says so; one of (2, 4, 4) full samples is shown without them (bricks
    planned at its first axis' factor, 2, put its triangles in the wrong bricks)."""
    from isoscope.core.budget import MemoryBudget
    shape = tuple(int(64 / f) for f in coarsest)
    path = write_pyramid(tmp_path / "p.ome.zarr", [(64, 64, 64), (32, 32, 32), shape],
                         [(1.0,) * 3, (2.0,) * 3, coarsest])
    volume = open_volume(str(path))
    budget = MemoryBudget(512 << 20, "test")
    refusal = lambda shape: "over the test's limit" if np.prod(shape) > 16 ** 3 * 2 else None   # noqa: E731
    shown, step, view, note = shown_in_bricks(volume, budget, refusal)
    assert shown.data.shape == shape
    assert "to fit this GPU's limits (over the test's limit)" in note
    if bricks:
        assert step == 4 and view is not None and view.layout.step == 4
        assert "the bricks in view refined to full resolution from the full level within the memory budget" in note
    else:
        assert view is None and "bricks in view" not in note


@pytest.mark.parametrize("zarr_format", [2, 3])
def test_the_spatial_axes_unit_comes_with_every_time_point_and_coarse_view(tmp_path, zarr_format):
    """Axes t (seconds), z, y, x (micrometres): the volume's length unit is the spatial axes' (a time unit is
    no length), at every time point and in the viewer's views from a pyramid level or every other sample."""
    from isoscope.viewer.model.big_volume import every_step, from_level
    rng = np.random.default_rng(7)
    axes = [{"name": "t", "type": "time", "unit": "second"},
            *({"name": a, "type": "space", "unit": "micrometer"} for a in "zyx")]
    write_ome(tmp_path / "t.ome.zarr", [rng.random((2, 16, 16, 16), "f4"), rng.random((2, 8, 8, 8), "f4")],
              [[1.0, 0.5, 0.5, 0.5], [1.0, 1.0, 1.0, 1.0]], axes=axes, zarr_format=zarr_format)
    for time in (0, 1):
        volume = open_volume(str(tmp_path / "t.ome.zarr"), time=time)
        assert volume.length_unit == "micrometer" and volume.time_points == 2
        assert from_level(volume, volume.pyramid[0])[0].length_unit == "micrometer"
        assert every_step(volume, 2).length_unit == "micrometer"

"""The viewer's model without GL: ViewerState and its parts built on numpy volumes, no context made.

The GPU side follows the state once a frame (gfx/scene.py, tested with a real context elsewhere in
tests/viewer); what is checked here is that the state alone keeps its promises: values clamped to the
volume's range, refusals raised in their rule's words with nothing changed, one source for each
setting, background jobs answering with the id they were asked with.
"""
from __future__ import annotations

import ast
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

from isoscope.options import MeshOptions, MeshOptionsError
from isoscope.viewer.model.errors import ViewerError
from isoscope.viewer.model.jobs import Jobs
from isoscope.viewer.model.levels import MAX_LEVELS
from isoscope.viewer.model.state import ViewerState
from isoscope.volumes.volume import finish_volume

MODEL = Path(__file__).resolve().parents[3] / "app" / "viewer" / "model"


def ramp(shape=(12, 10, 8), direction="descent"):
    """Values 0 .. 11 along axis 0."""
    data = np.broadcast_to(np.arange(shape[0], dtype=np.float32)[:, None, None], shape).copy()
    return finish_volume(data, spacing=(1.0, 1.0, 1.0), name="ramp", source="ramp",
                         gradient_direction=direction, default_level=None)


@pytest.fixture
def state():
    state = ViewerState()
    state.show(ramp())
    return state


def test_nothing_under_model_imports_moderngl():
    for path in MODEL.glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            names = [alias.name for alias in node.names] if isinstance(node, ast.Import) else \
                [node.module or ""] if isinstance(node, ast.ImportFrom) else []
            assert not any(name.split(".")[0] in ("moderngl", "glfw", "imgui_bundle") for name in names), path
    loaded = subprocess.run([sys.executable, "-c", "import sys, isoscope.viewer.model.state; "
                             "print(sorted({'moderngl', 'glfw', 'imgui_bundle'} & set(sys.modules)))"],
                            capture_output=True, text=True, timeout=60)
    assert loaded.stdout.strip() == "[]", loaded.stderr


def test_the_viewers_layers_point_down():
    """model/ imports nothing of gfx/ or ui/; gfx/ nothing of ui/."""
    from test_layers import import_graph
    rank = {"model": 0, "gfx": 1, "ui": 2}

    def layer(name):
        parts = name.split(".")
        return rank.get(parts[2]) if len(parts) > 2 and parts[1] == "viewer" else None
    wrong = sorted(f"{name} -> {target}" for name, targets in import_graph().items() if layer(name) is not None
                   for target in targets if layer(target) is not None and layer(target) > layer(name))
    assert not wrong, wrong


def test_levels_live_in_the_volumes_value_range(state):
    assert state.value_range == state.volume.value_range == (0.0, 11.0)   # the slider's ends: the volume's
    assert state.iso == 5.5                               # no default level: the middle
    state.iso = 40.0
    assert state.iso == 11.0
    state.levels.set_value(-3)
    assert state.iso == 0.0
    state.levels.nudge(+0.10)
    assert state.iso == pytest.approx(1.1)
    state.levels.add(7.0)
    assert state.levels.values() == [pytest.approx(1.1), 7.0] and state.levels.selected == 1
    state.iso = 99.0   # the slider moves the selected level only
    assert state.levels.values() == [pytest.approx(1.1), 11.0]


def test_a_refused_level_change_raises_its_one_line_and_changes_nothing(state):
    before = (state.levels.values(), state.levels.selected)
    for change, words in ((lambda: state.levels.add(12.5), "outside the value range 0 .. 11"),
                          (lambda: state.levels.set_opacity(0, 2.0), "outside 0..1"),
                          (lambda: state.levels.select(3), "no surface 4; there are 1"),
                          (lambda: state.levels.remove(0), "cannot be removed; hide it instead"),
                          (lambda: state.levels.set_color(0, (1, 2)), "three values")):
        with pytest.raises(ViewerError, match=words):
            change()
        assert (state.levels.values(), state.levels.selected) == before
    for value in range(1, MAX_LEVELS):
        state.levels.add(value)
    with pytest.raises(ViewerError, match=f"at most {MAX_LEVELS} surfaces"):
        state.levels.add(5.0)


def test_a_refused_mesh_option_pair_raises_the_rule_and_leaves_the_state(state):
    assert state.set_smooth(2) is True
    options = state.mesh_options
    with pytest.raises(MeshOptionsError) as caught:
        state.set_sharp(30)
    assert str(caught.value) == MeshOptions(smooth=2, sharp=30.0).problem()   # the spec's one wording
    assert state.mesh_options is options and state.mesh_options.sharp is None and state.mesh_options.smooth == 2
    with pytest.raises(ValueError, match="whole number of iterations"):
        state.set_smooth(-1)
    assert state.mesh_options is options
    assert state.set_smooth(0) and state.set_sharp(30)
    with pytest.raises(MeshOptionsError, match="not with tetrahedra"):
        state.set_cells("tetrahedra")
    assert state.mesh_options.cells == "cubes"
    assert state.set_sharp(30) is False   # no change


def test_each_mesh_option_has_one_source(state):
    # cells, smoothing and sharp features are one MeshOptions, replaced whole; nothing else holds them.
    assert not {"cells", "smooth", "sharp"} & set(vars(state))
    state.set_cells("tetrahedra")
    state.set_smooth(3)
    assert state.mesh_options == MeshOptions(cells="tetrahedra", smooth=3)
    assert (state.mesh_options.cells, state.mesh_options.smooth, state.mesh_options.sharp) == ("tetrahedra", 3, None)


def test_a_job_answers_with_its_request_id_and_a_stale_answer_is_dropped():
    jobs, release = Jobs(), threading.Event()

    def slow(value, progress):
        progress(0.5, "half way")
        release.wait(30)
        return value

    def fast(value, progress):
        return value

    first = jobs.submit("open", slow, "first")
    assert jobs.current("open").request_id == first and jobs.current("open").message == "half way"
    second = jobs.submit("open", fast, "second")
    assert second != first
    answers = jobs.poll(wait_s=30)
    assert [(a.request_id, a.value) for a in answers] == [(second, "second")]
    release.set()
    old = [job for job in jobs._running if job.request_id == first][0]
    assert old.done(wait_s=30) and old.response.request_id == first   # it answered, with its own id ...
    assert jobs.poll() == []                                           # ... too late: dropped
    assert jobs.current("open") is None


def test_a_failed_job_answers_with_its_error_and_a_bug_in_one_line():
    jobs = Jobs()

    def unreadable(progress):
        raise OSError("no such file: x.npy")

    def buggy(progress):
        raise RecursionError("maximum recursion depth exceeded\nwhile parsing")

    jobs.submit("a", unreadable)
    jobs.submit("b", buggy, failure="could not open expr:x")
    answers = {a.kind: a for a in jobs.poll(wait_s=30)}
    assert str(answers["a"].error) == "no such file: x.npy"
    assert isinstance(answers["b"].error, ViewerError)
    assert str(answers["b"].error) == "could not open expr:x: RecursionError: maximum recursion depth exceeded " \
                                      "while parsing"


def test_opening_a_file_is_a_request_answered_with_its_volume(tmp_path):
    np.save(tmp_path / "noise.npy", np.random.default_rng(1).normal(size=(12, 10, 8)).astype(np.float32))
    state = ViewerState()
    request = state.opening.open(str(tmp_path / "noise.npy"))
    (answer,) = state.jobs.poll(wait_s=60)
    assert answer.request_id == request and state.volume is None   # the GPU side puts it on show
    opened = state.opening.opened(answer)
    assert opened.volume.data.shape == (12, 10, 8) and opened.step == 1
    assert state.recent.paths == [str((tmp_path / "noise.npy").resolve())]
    state.opening.open(str(tmp_path / "missing.npy"))
    (answer,) = state.jobs.poll(wait_s=60)
    with pytest.raises(ValueError, match="no such file"):
        state.opening.opened(answer)


def test_slices_and_the_window_refuse_what_does_not_fit(state):
    slices = state.slices
    assert slices.shape == (12, 10, 8) and slices.index == [5, 4, 3]
    slices.show(2, True, 7)
    before = (list(slices.shown), list(slices.index), slices.window, slices.centre)
    with pytest.raises(ValueError, match="z=8 is outside the volume; z runs from 0 to 7"):
        slices.show(2, True, 8)
    with pytest.raises(ValueError, match="window -1 must be a positive number"):
        slices.set_window(-1.0)
    assert (list(slices.shown), list(slices.index), slices.window, slices.centre) == before
    slices.set_window(2.0, 4.0)   # the window's width and centre (the command line's --window/--level)
    assert (slices.window, slices.centre) == (2.0, 4.0)


def test_the_object_side_is_the_volumes_gradient_direction(state):
    assert state.gradient_direction == "descent"
    assert state.set_gradient_direction("ascent") is True and state.volume.gradient_direction == "ascent"
    assert state.slice_scene.gradient_direction == "ascent"
    assert state.set_gradient_direction("ascent") is False
    with pytest.raises(ViewerError, match="descent, ascent"):
        state.set_gradient_direction("below")


def test_a_label_map_is_listed_without_extracting_it():
    labels = np.zeros((8, 8, 8), np.uint8)
    labels[1:4, 1:4, 1:4], labels[5:7, 5:7, 5:7] = 3, 9
    state = ViewerState()
    volume = finish_volume(labels, spacing=(1.0, 1.0, 1.0), name="seg", source="seg",
                           gradient_direction="descent", default_level=None)
    state.show(volume)
    assert state.label_hint == 2 and not state.labels
    assert state.show_labels()
    assert [layer.label for layer in state.labels.layers] == [3, 9]
    assert len({layer.color for layer in state.labels.layers}) == 2
    state.labels.set_visible(9, False)
    assert [layer.label for layer in state.labels.visible()] == [3]
    with pytest.raises(ViewerError, match="no label 4 on show"):
        state.labels.set_visible(4, True)
    state.show(finish_volume(labels.astype(np.float32) + 0.5, spacing=(1.0, 1.0, 1.0), name="soft", source="soft",
                             gradient_direction="descent", default_level=None))
    assert not state.labels   # a new volume: back to its levels
    with pytest.raises(ValueError, match="not a label map"):
        state.show_labels()
    assert not state.labels


def test_the_panel_shows_a_refusal_in_one_line_and_clears_it_on_success(state):
    from isoscope.viewer.ui.gui import act  # imgui's Python module: no context, no window
    state.set_smooth(2)
    assert act(state, state.set_sharp, 30) is False
    assert state.error == MeshOptions(smooth=2, sharp=30.0).problem() and state.mesh_options.sharp is None
    assert act(state, state.set_smooth, 0) is True and state.error is None

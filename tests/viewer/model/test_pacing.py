"""The moving level's preview step chosen from measured frame times (viewer/model/pacing.py): no GL.

The frames are simulated with a cost model of their own (a floor plus extraction falling with the cells and
drawing with the triangles, with noise), and the best step is found by trying every one."""
import numpy as np
import pytest

from isoscope.viewer.model.pacing import FramePace, estimated_ms, pace_text, paced_step


def test_with_nothing_measured_the_first_guess_stands_within_the_steps_allowed():
    assert paced_step({}, first_guess=3, max_step=8) == 3
    assert paced_step({}, first_guess=12, max_step=8) == 8
    assert paced_step({}, first_guess=0, max_step=8) == 1
    assert FramePace().step(first_guess=5, max_step=4) == 4


def test_a_measured_step_counts_as_measured_and_others_scale_with_the_triangles_above_the_floor():
    measured = {4: 30.0}
    assert estimated_ms(4, measured, floor_ms=10.0) == 30.0
    assert estimated_ms(2, measured, floor_ms=10.0) == pytest.approx(10 + 20 * 4)
    assert estimated_ms(8, measured, floor_ms=10.0) == pytest.approx(10 + 20 / 4)
    assert estimated_ms(3, {}) is None
    # the nearest measurement speaks; two as near: the slower estimate
    assert estimated_ms(3, {2: 100.0, 6: 12.0}) == pytest.approx(100 * 4 / 9)
    assert estimated_ms(4, {2: 100.0, 6: 30.0}) == pytest.approx(max(100 / 4, 30 * 9 / 4))
    # a floor near the measured frame (noise, a busy rest frame) does not make every step look free: half
    # the measured frame at least is work
    assert estimated_ms(2, {4: 8.0}, floor_ms=20.0) == pytest.approx(4 + 4 * 4)


def test_the_finest_step_within_the_target_is_chosen_and_a_slow_measured_step_is_not():
    # step 2 was measured too slow: the step stays at 3 even though an estimate from 3 alone would allow 2
    assert paced_step({2: 70.0, 3: 20.0}, first_guess=5, max_step=8, target_ms=40.0) == 3
    assert paced_step({3: 20.0}, first_guess=5, max_step=8, target_ms=50.0) == 2   # 20 * 9/4 = 45
    assert paced_step({3: 20.0}, first_guess=5, max_step=8, target_ms=40.0) == 3
    assert paced_step({1: 25.0}, first_guess=4, max_step=8, target_ms=40.0) == 1   # a small mesh: full at once
    # every step too slow: the coarsest allowed
    assert paced_step({8: 90.0}, first_guess=2, max_step=8, target_ms=40.0) == 8


def frame_ms(step, rng, floor=13.0, extract=900.0, draw=600.0, noise=0.1):
    """One simulated frame: a floor, extraction falling with the cells, drawing with the triangles."""
    return (floor + extract / step ** 3 + draw / step ** 2) * (1 + noise * rng.uniform(-1, 1))


def finest_step(target, **model):
    """The finest step whose noiseless frame fits `target`, by trying each."""
    rng = np.random.default_rng(0)
    return next(step for step in range(1, 9) if frame_ms(step, rng, noise=0.0, **model) <= target)


@pytest.mark.parametrize("model", [dict(), dict(extract=3000.0, draw=100.0), dict(extract=50.0, draw=1200.0),
                                   dict(floor=30.0, extract=200.0, draw=200.0)])
@pytest.mark.parametrize("first_guess", [1, 3, 8])
def test_a_simulated_drag_settles_on_the_best_step_and_keeps_frames_under_the_target(model, first_guess):
    target, noise = 40.0, 0.1
    rng = np.random.default_rng(7)
    pace = FramePace(target_ms=target)
    for _ in range(5):   # frames at rest: the floor
        pace.record_floor(frame_ms(1, rng, extract=0.0, draw=0.0, floor=model.get("floor", 13.0)))
    steps, frames = [], []
    for _ in range(200):
        step = pace.step(first_guess, max_step=8)
        ms = frame_ms(step, rng, noise=noise, **model)
        pace.record(step, ms)
        steps.append(step)
        frames.append(ms)
    # After a few frames: a step that may fit (within the noise) and no coarser than one that surely fits.
    finest, sure = finest_step(target * (1 + noise), **model), finest_step(target * (1 - noise), **model)
    settled = np.array(steps[10:])
    assert np.mean((settled >= finest) & (settled <= sure)) > 0.95, (finest, sure, np.bincount(settled))
    assert np.median(frames[10:]) < target
    assert np.percentile(frames[10:], 90) < target * (1 + noise)   # a slow step tried again only now and then


def test_a_step_measured_long_ago_is_forgotten_and_tried_again():
    pace = FramePace(target_ms=40.0, recent=3, forget_after=10)
    pace.record(2, 80.0)   # too slow
    for _ in range(5):
        pace.record(3, 20.0)
    assert pace.step(first_guess=3, max_step=8) == 3
    for _ in range(10):
        pace.record(3, 15.0)
    assert 2 not in pace.measured
    assert pace.step(first_guess=3, max_step=8) == 2   # 15 * 9/4 = 33.75: worth a try again
    pace.forget()
    assert pace.measured == {} and pace.floor_ms == 0.0
    assert pace.step(first_guess=6, max_step=8) == 6


def test_a_step_time_is_the_median_of_its_recent_frames():
    pace = FramePace(recent=5)
    for ms in (20.0, 21.0, 400.0, 22.0, 19.0):   # one stall (a page fault, a JIT) does not move it
        pace.record(4, ms)
    assert pace.measured == {4: 21.0}
    for ms in (60.0, 61.0, 62.0):                # the scene got slower: three frames say so
        pace.record(4, ms)
    assert pace.measured[4] == 60.0


def test_the_stats_tooltip_says_what_chose_the_step():
    pace = FramePace(target_ms=40.0)
    assert "triangle budget" in pace_text(pace)
    for step, ms in ((8, 21.0), (7, 33.4), (6, 52.0)):
        pace.record(step, ms)
    assert pace_text(pace) == ("the finest step whose frames keep under 40 ms while the level moves "
                               "(else the coarsest); measured 1/6 52 ms, 1/7 33 ms, 1/8 21 ms")

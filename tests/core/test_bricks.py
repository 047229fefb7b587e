"""Which bricks of a volume past the budget go to full resolution (core/bricks.py): no GL.

Cameras are made as the viewer makes them (pyrr look-at and perspective, row vectors); what is in view is
checked against a dense sampling of each brick's box projected to clip space, and nearness against the
distance to the box's nearest sample point."""
import numpy as np
import pytest
from pyrr import matrix44

from isoscope.core.bricks import (
    brick_bytes,
    brick_room,
    bricks_of,
    distances,
    in_view,
    plan_refinement,
)
from isoscope.core.budget import BudgetError, MemoryBudget

SHAPE = (1024, 1024, 700)
SPACING = (0.5, 0.5, 0.8)


def camera(eye, target, fov=35.0, aspect=1.6, near=1.0, far=5000.0):
    """(eye, clip matrix for column vectors) as the viewer's OrbitCamera builds them."""
    view = matrix44.create_look_at(np.asarray(eye, float), np.asarray(target, float), np.array([0.0, 0.0, 1.0]))
    projection = matrix44.create_perspective_projection(fov, aspect, near, far)
    return np.asarray(eye, float), (view @ projection).T


def sample_points(brick, spacing, n=7):
    lower, upper = brick.box(spacing)
    axes = [np.linspace(a, b, n) for a, b in zip(lower, upper)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)


def seen(brick, spacing, clip):
    """Whether any of the box's sample points lands inside the clip volume."""
    points = sample_points(brick, spacing)
    c = np.concatenate([points, np.ones((len(points), 1))], axis=1) @ clip.T
    w = c[:, 3:4]
    return bool(np.any(np.all(np.abs(c[:, :3]) <= w, axis=1) & (w[:, 0] > 0)))


def test_bricks_cover_every_cell_once_and_neighbours_share_their_face_samples():
    bricks = bricks_of(SHAPE, 128)
    assert len(bricks) == 8 * 8 * 6
    assert sum(np.prod(np.subtract(b.end, b.first)) for b in bricks) == np.prod(np.subtract(SHAPE, 1))
    by_index = {b.index: b for b in bricks}
    for brick in bricks:
        for axis in range(3):
            step = list(brick.index)
            step[axis] += 1
            right = by_index.get(tuple(step))
            if right is not None:
                assert right.first[axis] == brick.end[axis]   # the shared face: one plane of samples in both
    assert max(b.end for b in bricks) == tuple(n - 1 for n in SHAPE)
    assert bricks_of((40, 30, 20), 128)[0].samples == 40 * 30 * 20   # a small volume is one brick


@pytest.mark.parametrize("seed", range(6))
def test_a_brick_any_of_whose_samples_is_on_screen_counts_as_in_view(seed):
    rng = np.random.default_rng(seed)
    bricks = bricks_of(SHAPE, 128)
    centre = np.subtract(SHAPE, 1) * SPACING / 2
    eye = centre + rng.normal(0, 1, 3) * rng.uniform(50, 700)
    target = centre + rng.normal(0, 120, 3)
    eye, clip = camera(eye, target, fov=rng.uniform(20, 60))
    shown = in_view(bricks, SPACING, clip)
    reference = np.array([seen(b, SPACING, clip) for b in bricks])
    assert not np.any(reference & ~shown)          # no brick on screen is left out
    assert shown.sum() <= reference.sum() + 0.05 * len(bricks)   # and culls the rest (bar a few beside corners)


def test_a_camera_close_to_one_corner_sees_only_what_is_before_it():
    bricks = bricks_of(SHAPE, 128)
    eye, clip = camera((-40.0, -40.0, 100.0), (60.0, 60.0, 100.0), fov=30)   # outside a corner, looking in
    shown = in_view(bricks, SPACING, clip)
    assert 0 < shown.sum() < len(bricks) // 2
    _, away = camera((-40.0, -40.0, 100.0), (-140.0, -140.0, 100.0))      # looking away: nothing
    assert not in_view(bricks, SPACING, away).any()


def test_distances_are_to_the_nearest_point_of_each_box():
    bricks = bricks_of(SHAPE, 128)
    eye = np.array([100.0, -30.0, 260.0])
    got = distances(bricks, SPACING, eye)
    for brick, d in zip(bricks[::37], got[::37]):
        points = sample_points(brick, SPACING, n=65)
        nearest = np.linalg.norm(points - eye, axis=1).min()
        assert d <= nearest + 1e-9 and nearest - d < 1.0   # the box's nearest point, to the sampling's grain


def test_the_bricks_chosen_are_in_view_nearest_first_within_the_room():
    bricks = bricks_of(SHAPE, 128)
    per_sample = 2.75
    room = 40 * brick_bytes(bricks[0], per_sample) + 12_345
    centre = np.subtract(SHAPE, 1) * SPACING / 2
    eye, clip = camera(centre + np.array([0.0, -420.0, 60.0]), centre)
    plan = plan_refinement(bricks, set(), eye, clip, room, per_sample, SPACING)
    chosen = {b.index for b in plan.wanted}
    assert plan.load == plan.wanted and plan.kept == () and plan.drop == ()
    assert 30 <= len(chosen) and plan.bytes == sum(brick_bytes(b, per_sample) for b in plan.wanted) <= room
    shown = in_view(bricks, SPACING, clip)
    near = distances(bricks, SPACING, eye)
    assert all(shown[bricks.index(b)] for b in plan.wanted)
    loaded = [near[bricks.index(b)] for b in plan.wanted]
    assert loaded == sorted(loaded)
    left_out = [near[i] for i, b in enumerate(bricks) if shown[i] and b.index not in chosen]
    assert left_out and min(left_out) >= max(loaded)   # no brick shown coarse is nearer than one in full


def test_zooming_in_refines_what_is_in_view_and_far_bricks_coarsen_only_when_memory_is_needed():
    bricks = bricks_of(SHAPE, 128)
    per_sample = 2.75
    one = brick_bytes(bricks[0], per_sample)
    centre = np.subtract(SHAPE, 1) * SPACING / 2
    eye, clip = camera(centre + np.array([0.0, -600.0, 0.0]), centre)
    first = plan_refinement(bricks, set(), eye, clip, 30 * one, per_sample, SPACING)
    refined = {b.index for b in first.wanted}
    # zoomed in on the far +x side: other bricks in view, nearer ones first; the old ones stay while room is left
    corner = np.subtract(SHAPE, 1) * SPACING * np.array([0.95, 0.9, 0.5])
    eye2, clip2 = camera(corner + np.array([60.0, 0.0, 0.0]), corner)
    roomy = plan_refinement(bricks, refined, eye2, clip2, len(bricks) * one, per_sample, SPACING)
    assert roomy.load and not roomy.drop and {b.index for b in roomy.kept} | {b.index for b in roomy.wanted} >= refined
    tight = plan_refinement(bricks, refined, eye2, clip2, 30 * one, per_sample, SPACING)
    assert tight.drop and tight.bytes <= 30 * one
    near = distances(bricks, SPACING, eye2)
    kept = [near[bricks.index(b)] for b in tight.kept]
    dropped = [near[bricks.index(b)] for b in tight.drop]
    assert not kept or max(kept) <= min(dropped)   # the farthest go back to coarse first
    assert dropped == sorted(dropped, reverse=True)
    after = refined - {b.index for b in tight.drop} | {b.index for b in tight.load}
    assert after == {b.index for b in tight.wanted} | {b.index for b in tight.kept}


def test_the_room_leaves_a_coarse_view_and_a_budget_below_one_brick_is_one_line():
    step, room = brick_room(SHAPE, 2, MemoryBudget(2 << 30, "--memory-budget"))
    assert step >= 2 and room >= brick_bytes(bricks_of(SHAPE)[0], 2.75)
    assert room < (2 << 30) * 0.75
    with pytest.raises(BudgetError) as caught:
        brick_room(SHAPE, 2, MemoryBudget(4 << 20, "--memory-budget"))
    message = str(caught.value)
    assert "\n" not in message and "one 128^3 brick" in message and "give --memory-budget" in message
    need = int(message.split("give --memory-budget ")[1].split("M")[0])
    brick_room(SHAPE, 2, MemoryBudget(need << 20, "--memory-budget"))   # what it asks for is enough
    for too_little in (need // 2, need // 4):   # the room, three quarters of it, is below one brick
        with pytest.raises(BudgetError):
            brick_room(SHAPE, 2, MemoryBudget(too_little << 20, "--memory-budget"))


def test_on_a_software_renderer_the_room_leaves_out_its_copy_of_the_coarse_image_and_the_step_stays():
    """llvmpipe keeps the coarse view's volume image in the process's RAM beside its samples: the bricks' room
    is that much smaller, the coarse view the same; a budget asked for in the refusal is still enough."""
    gpu = brick_room(SHAPE, 2, MemoryBudget(256 << 20, "--memory-budget"))
    software = brick_room(SHAPE, 2, MemoryBudget(256 << 20, "--memory-budget", software=True))
    coarse = np.prod([len(range(0, n, gpu[0])) for n in SHAPE])
    assert software[0] == gpu[0] and gpu[1] - software[1] == coarse * 2
    with pytest.raises(BudgetError) as caught:
        brick_room(SHAPE, 2, MemoryBudget(4 << 20, "--memory-budget", software=True))
    need = int(str(caught.value).split("give --memory-budget ")[1].split("M")[0])
    brick_room(SHAPE, 2, MemoryBudget(need << 20, "--memory-budget", software=True))

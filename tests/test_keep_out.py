"""The keep-out check of the action search (tognet.policies.keep_out): a bar on a ray-cast table, taken into
the gripper's frame from the depth image alone, carried to pulling's start pose, and its clearance from the
can; and the shipped pulling model's search, which with the check on never brings the bar down on the can."""

from dataclasses import replace

import numpy as np
import pytest

from tognet.grasping.antipodal import AntipodalConfig, sample_antipodal
from tognet.grasping.crops import resolve_crop
from tognet.grasping.depth import prepare_depth
from tognet.grasping.synthetic import Box, render_depth, tilted_camera
from tognet.jobs.models import load_model
from tognet.policies.action_search import ActionSearchGrasps, view_penalty
from tognet.policies.config import ActionSearchConfig
from tognet.policies.keep_out import clearance, footprints
from tognet.policies.view import SceneView
from tognet.tasks import get_task

#: A 30 x 2 x 2 cm bar along world x centred at the origin, and a block 25 cm to its side (another object).
BAR = Box.on_table(0.0, 0.0, (0.30, 0.02, 0.02))
BLOCK = Box.on_table(0.0, 0.25, (0.06, 0.06, 0.04))
#: Across the bar 10 cm from its -x end, 5 mm above the table, jaw axis along world -y: the bar reaches 25 cm
#: along the gripper's +y.
GRASP = np.array([[-0.10, 0.0, 0.005, -np.pi / 2]])
PIXEL = 0.004  # m: a little more than a pixel at 0.9 m with the Kinect 2 intrinsics


@pytest.fixture(scope="module")
def scene():
    camera = tilted_camera(0.9)
    return prepare_depth(render_depth(camera, [BAR, BLOCK]), camera)


def test_the_object_under_the_grasp_lands_in_the_gripper_frame_and_no_other(scene):
    fp = footprints(scene, GRASP)
    x, y = fp.xy[0, :, 0], fp.xy[0, :, 1]
    assert fp.seen[0]
    assert y.min() == pytest.approx(-0.05, abs=PIXEL) and y.max() == pytest.approx(0.25, abs=PIXEL)
    assert np.abs(x).max() < 0.01 + PIXEL  # the bar's width, not the block 25 cm away
    assert np.all(fp.low[0] == pytest.approx(-0.005)) and fp.high[0].max() == pytest.approx(0.015, abs=0.002)


def test_a_grasp_beside_every_object_sees_none(scene):
    fp = footprints(scene, np.array([[0.2, -0.2, 0.01, 0.0]]))
    assert not fp.seen[0]


@pytest.mark.parametrize(("a_y", "a_z", "expected"), [
    (-0.06, 0.0, -0.033),   # the bar through the can's axis
    (0.0, 0.0, 0.017),      # its side 5 cm from the axis: 1.7 cm clear of the can's side
    (0.06, 0.0, 0.077),     # 11 cm from the axis
    (-0.06, 0.06, np.inf),  # through the axis, its bottom 5 mm above the can's top: it passes over
])
def test_clearance_from_the_can_at_the_start_pose(scene, a_y, a_z, expected):
    task = get_task("pulling")
    fp = footprints(scene, GRASP)
    got = clearance(fp, np.array([0]), np.array([[[0.0, a_y, a_z, 0.0]]]), task, task.keep_out())[0, 0]
    if np.isinf(expected):
        assert np.isinf(got)
    else:
        assert got == pytest.approx(expected, abs=PIXEL)


def test_turning_the_start_yaw_swings_the_bar_onto_the_can_or_away(scene):
    """The can lies 16 cm ahead of the gripper and 6 cm to its -y at a = 0, at 20.6 degrees: turning the
    start yaw by that much lays the bar across it, turning it the other way swings it further off."""
    task = get_task("pulling")
    fp = footprints(scene, GRASP)
    acts = np.array([[[0.0, 0.0, 0.0, a] for a in (-np.arctan2(0.06, 0.16), 0.0, np.pi / 4)]])
    onto, straight, away = clearance(fp, np.array([0]), acts, task, task.keep_out())[0]
    assert onto < -0.02 and 0 < straight < away


def test_tasks_without_fixed_props_get_no_penalty(scene):
    cands = sample_antipodal(scene, None, AntipodalConfig(), np.random.default_rng(0))
    on = ActionSearchConfig(keep_out=True)
    for name in ("hammering", "sweeping"):
        view = SceneView(scene, cands, get_task(name), resolve_crop([]))
        assert view_penalty(view, cands.grasps, on) is None
    pulling = SceneView(scene, cands, get_task("pulling"), resolve_crop([]))
    assert view_penalty(pulling, cands.grasps, ActionSearchConfig()) is None
    assert view_penalty(pulling, cands.grasps, on) is not None


def test_the_search_keeps_the_bar_off_the_can_only_with_the_check_on(scene):
    """With a margin so wide that most of the box is ruled out, the search's pick keeps it; without the
    check, the shipped model's pick on this bar does not (so the check is what keeps it)."""
    model = load_model("tognet/models/pulling_search.pt")
    task = get_task("pulling")
    cands = sample_antipodal(scene, None, AntipodalConfig(axis_direction="both"), np.random.default_rng(0))
    view = SceneView(scene, cands, task, resolve_crop([model]))
    margin = 0.06
    picks = {}
    for on in (False, True):
        cfg = replace(ActionSearchConfig(), keep_out=on, keep_out_margin=margin)
        view.cache.clear()
        grasps, res = ActionSearchGrasps(model, cfg).result(view, np.random.default_rng(1))
        fp = footprints(scene, grasps[res.index])
        rows = np.arange(len(res.index))
        picks[on] = clearance(fp, rows, res.actions[:, None], task, task.keep_out())[:, 0]
    assert np.all(picks[True] >= margin)
    assert np.any(picks[False] < margin)

"""Two tools touching in one region of a user's depth image are split in two, or reported (issue 35 item 5);
one tool, however narrow its neck, is neither.

The images are rendered here: procedurally generated tools (``tognet objects generate``'s generator) settled
on a table by MuJoCo, alone, side by side with their collision geoms 1 mm apart, or one dropped across the
other, photographed from 0.6-0.9 m (straight down or tilted 10-25 degrees) through a sensor model (range
noise, dropouts, lost silhouettes). Which tool each pixel shows is known, so a split is checked against the
tools themselves.
"""

import numpy as np
import pytest
from touching_testlib import KINECT2, REALSENSE, aim, outcome, owners, render, settle

from tognet.geometry import Camera
from tognet.grasping.depth import height_map
from tognet.grasping.synthetic import Box, render_depth, t_shape
from tognet.objects.generate import generate_set
from tognet.objects.handmade import make_test_tools
from tognet.planning.segment import SegmentConfig, segment_objects, table_noise
from tognet.planning.table import plane_from_pose
from tognet.sim.glcamera import SensorModel

VIEWS = [(KINECT2, 0.7, 0.0), (REALSENSE, 0.8, 20.0), (KINECT2, 0.9, 25.0), (REALSENSE, 0.6, 10.0)]
COUNT = 8  # tools of each procedural kind


@pytest.fixture(scope="module")
def tools(tmp_path_factory):
    root = tmp_path_factory.mktemp("tools")
    return {kind: generate_set(kind, "test", COUNT, root / kind) for kind in ("primitive", "complex")}


def _image(scene, seed):
    """(depth as the sensor reads it, the camera in the table frame, the clean image's camera)."""
    k, distance, tilt = VIEWS[seed % len(VIEWS)]
    camera = aim(scene, k, distance, tilt, azimuth=float(seed))
    clean = render(scene.meshes, camera)
    depth = SensorModel().apply(clean, np.random.default_rng(seed))
    return depth, Camera(k, plane_from_pose(camera.pose).table_from_camera()), camera, clean


def _segment(depth, camera, config=None):
    height = height_map(depth, camera)
    return segment_objects(height, depth, camera.intrinsics, camera.pose, config, table_noise(height, depth))


def _flagged(objects):
    return [o for o in objects if o.touching is not None]


@pytest.mark.parametrize("kind", ["primitive", "complex"])
def test_no_single_generated_tool_is_split_or_reported(kind, tools):
    for i, record in enumerate(tools[kind]):
        depth, camera, _, _ = _image(settle([record], "alone", seed=i), seed=i)
        found = _segment(depth, camera)
        assert [o for o in found if o.qualifies], f"{record.object_id}: no object found"
        assert not _flagged(found), f"{record.object_id}: {_flagged(found)[0].touching}"
        assert len([o for o in found if o.qualifies]) == 1


def test_a_hammer_with_a_thin_handle_and_a_big_head_is_one_object(tmp_path):
    """The hand-made T hammer (2.5 cm handle, its head 4 x 4 x 12 cm), a long thin-handled mallet and a
    sledge with a 1.2 cm handle: the neck where handle meets head is narrow, and they are one object."""
    hammer = make_test_tools(tmp_path)["t_hammer"]
    depth, camera, _, _ = _image(settle([hammer], "alone", seed=1), seed=1)
    assert not _flagged(_segment(depth, camera))
    shapes = (((0.3, 0.012, 0.012), (0.05, 0.14, 0.05)), ((0.25, 0.02, 0.015), (0.06, 0.09, 0.04)))
    for handle, head in shapes:
        for yaw in (0.0, 0.7, 2.0):
            cam = Camera.aimed_at(REALSENSE, [0.0, 0.0, 0.0], 0.7, 0.3, yaw, 0.0)
            clean = render_depth(cam, t_shape(0.0, 0.0, yaw=yaw, handle=handle, head=head))
            depth = SensorModel().apply(clean, np.random.default_rng(0))
            found = _segment(depth, Camera(REALSENSE, plane_from_pose(cam.pose).table_from_camera()))
            assert len(found) == 1 and not _flagged(found), [o.touching for o in found]


def _pairs(tools, arrangement, count):
    prim, comp = tools["primitive"], tools["complex"]
    for i in range(count):
        a, b = (prim, comp) if i % 2 else (prim, prim) if i % 4 == 0 else (comp, comp)
        yield i, a[i % COUNT], b[(3 * i + 1) % COUNT]


def test_two_tools_side_by_side_are_split_into_the_tools_or_reported(tools):
    """12 pairs slid together until their collision geoms are 1 mm apart. Measured on this batch: 2 split
    into the two tools (each half 80 % or more one tool), 1 split wrongly (part of one tool given to the
    other), 2 reported, 7 missed (tops meeting high, or a bar's end against the other tool: no valley,
    no narrow pinch, or a convex bar pointing into the joint as a handle does)."""
    seen = []
    for i, a, b in _pairs(tools, "side", 12):
        scene = settle([a, b], "side", seed=i)
        assert scene.gap < 0.0015  # touching, as the physics settled them
        depth, camera, true_camera, clean = _image(scene, seed=i)
        seen.append(outcome(_segment(depth, camera), owners(scene, true_camera, clean)))
    assert seen.count("split right") >= 2 and seen.count("split right") + seen.count("reported") >= 4, seen
    assert seen.count("split wrong") <= 1, seen


def test_the_split_objects_name_each_other_and_the_plan_says_so(tools):
    from tognet.planning.user import UserPlanner

    i, a, b = next((i, a, b) for i, a, b in _pairs(tools, "side", 12)
                   if outcome(*_found_and_owner(a, b, i)) == "split right")
    scene = settle([a, b], "side", seed=i)
    depth, camera, _, _ = _image(scene, seed=i)
    plan = UserPlanner("hammering").plan(depth, camera.intrinsics)
    halves = [o for o in plan.objects if o["split"]]
    assert len(halves) == 2
    j, other = plan.object["index"], next(o["index"] for o in halves if o["index"] != plan.object["index"])
    assert f"split from one region with #{other}" in plan.object["touching"]
    said = f"object #{j} is one of two objects touching, split from one region with #{other}: the lowest way"
    assert any(w.startswith(said) for w in plan.warnings), plan.warnings


def _found_and_owner(a, b, seed):
    scene = settle([a, b], "side", seed=seed)
    depth, camera, true_camera, clean = _image(scene, seed=seed)
    return _segment(depth, camera), owners(scene, true_camera, clean)


def test_a_pinch_between_two_blocks_is_reported_with_the_option_to_pick_one():
    """Two flat blocks (no valley between their tops) touching corner to corner: one region that pinches
    to a few millimetres; not split, but the plan's warning names the object and how to pick one."""
    from tognet.planning.user import UserPlanner

    camera = Camera.looking_down(KINECT2, [0.0, 0.0, 0.7])
    yaw = 0.6  # the second block's corner 5 mm inside the first's
    turn = np.array([[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]])
    corner = np.array([-0.005, -0.005]) - turn @ [-0.05, -0.03]
    blocks = [Box.on_table(-0.05, -0.03, (0.1, 0.06, 0.03)), Box.on_table(*corner, (0.1, 0.06, 0.03), yaw)]
    depth = SensorModel().apply(render_depth(camera, blocks), np.random.default_rng(0))
    found = _segment(depth, camera)
    assert len(found) == 1 and not found[0].split
    assert found[0].touching.startswith("may be two objects touching: its footprint narrows to ")
    off = _segment(depth, camera, SegmentConfig(touching=False))
    assert len(off) == 1 and off[0].touching is None
    plan = UserPlanner("hammering").plan(depth, camera.intrinsics, camera.pose)
    assert any(w.startswith("object #0 may be two objects touching: its footprint narrows to ")
               and w.endswith("; pick one with --object U,V (object= in tognet.plan)") for w in plan.warnings)


def test_one_tool_lying_across_another_is_counted(tools):
    """Measured, not solved: one tool dropped across another stays one region that is neither split nor
    reported (the top tool bridges the lower one's two sides, and an X-shaped tool looks the same; 0 of these
    8). The test holds that nothing is split wrongly."""
    seen = []
    for i, a, b in _pairs(tools, "across", 8):
        scene = settle([a, b], "across", seed=i)
        depth, camera, true_camera, clean = _image(scene, seed=i)
        seen.append(outcome(_segment(depth, camera), owners(scene, true_camera, clean)))
    assert "split wrong" not in seen, seen

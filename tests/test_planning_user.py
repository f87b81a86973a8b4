"""Planning on a user's own depth image: files, frames, table fit, tilted cameras, bad inputs (issue 13)."""

import json
import math

import numpy as np
import pytest
from typer.testing import CliRunner

from tognet.cli import app
from tognet.geometry import Camera, CameraIntrinsics
from tognet.geometry.transforms import invert_pose, make_pose
from tognet.grasping.synthetic import Box, render_depth, t_shape, tilted_camera
from tognet.planning.camera import load_intrinsics, save_camera_pose, save_depth_png, save_intrinsics
from tognet.planning.table import plane_from_pose
from tognet.planning.user import SIM_CAMERA_HEIGHT, UserPlanConfig, UserPlanner

TASK = "hammering"


@pytest.fixture(scope="module")
def checkpoints(tmp_path_factory):
    """Tiny TOG-Net checkpoints of both tasks (one epoch on synthetic episodes: inputs, not skill)."""
    from tognet.data.synthetic import write_synthetic_dataset
    from tognet.model.config import ArchConfig, TrainConfig
    from tognet.model.train import train

    root = tmp_path_factory.mktemp("models")
    arch = ArchConfig(stem_channels=8, block_channels=(8,), block_strides=(2,), bottleneck_channels=4,
                      z_features=8, head_hidden=16)
    cfg = TrainConfig(arch=arch, num_threads=1, epochs=1, batch_size=32, val_fraction=0.25, seed=0)
    out = {}
    for task in ("hammering", "sweeping"):
        data = write_synthetic_dataset(root / f"data-{task}", task=task, n=96, shard_size=96, seed=1,
                                       n_objects=8)
        out[task] = train([data], task, root / task, cfg, progress=False, log=lambda s: None).best_path
    return out


@pytest.fixture(scope="module")
def planner(checkpoints):
    return UserPlanner(TASK, checkpoints[TASK])


@pytest.fixture(scope="module")
def observation(tools):
    from tognet.sim import SimConfig, Simulator

    return Simulator(SimConfig(), TASK, tools["t_hammer"]).reset(3)


def _cli(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def _table_grasp(result_json):
    g = result_json["grasp"]["table"]
    return np.array([g["x"], g["y"], g["z"], g["phi"]])


def _world_of(table_grasp, table_from_camera, world_from_camera):
    """A table-frame grasp in the world, through a (possibly estimated) table frame."""
    world_from_table = world_from_camera @ invert_pose(table_from_camera)
    p = world_from_table @ np.array([*table_grasp[:3], 1.0])
    axis = world_from_table[:3, :3] @ np.array([math.cos(table_grasp[3]), math.sin(table_grasp[3]), 0.0])
    return p[:3], math.atan2(axis[1], axis[0]), axis


def _angle(a, b):
    return abs((a - b + math.pi) % (2 * math.pi) - math.pi)


# --- files and the simulator ------------------------------------------------------------------------------
def test_the_network_z_camera_is_the_simulators():
    from tognet.sim import SimConfig

    assert SimConfig().camera.position[2] == SIM_CAMERA_HEIGHT


@pytest.mark.parametrize("fmt", ["png", "npy", "npz", "npy-mm"])
def test_a_simulated_image_planned_through_the_cli_gives_the_simulators_grasp(
        fmt, tmp_path, checkpoints, planner, observation):
    """Saved in each format with its intrinsics and pose (the PNG by `tognet sim --depth-png`), planned by
    `tognet plan`: the same grasp and action as planning on the simulator's observation. Millimetre formats
    hold the image rounded to 1 mm: the same plan as on that rounded image."""
    obs = observation
    depth = obs.depth
    if fmt == "png":
        sim = _cli("sim", "--task", TASK, "--seed", 3, "--depth-png", tmp_path / "d.png")
        assert sim.exit_code == 0, sim.output
        path, intr, pose = tmp_path / "d.png", tmp_path / "d.intrinsics.json", tmp_path / "d.pose.json"
    else:
        intr = save_intrinsics(tmp_path / "k.json", obs.camera.intrinsics)
        pose = save_camera_pose(tmp_path / "pose.json", obs.camera.pose)
        path = tmp_path / ("d.npz" if fmt == "npz" else "d.npy")
        if fmt == "npz":
            np.savez_compressed(path, depth=depth)
        elif fmt == "npy":
            np.save(path, depth)
        else:
            np.save(path, np.nan_to_num(np.rint(depth * 1000), nan=0).astype(np.uint16))
    if fmt in ("png", "npy-mm"):
        depth = (np.rint(depth * 1000) / 1000).astype(np.float32)
    result = _cli("plan", "--depth", path, "--intrinsics", intr, "--camera-pose", pose, "--task", TASK,
                  "--checkpoint", checkpoints[TASK], "--out", tmp_path / "plan.json", "--overlay",
                  tmp_path / "plan.png")
    assert result.exit_code == 0, result.output
    via_cli = json.loads((tmp_path / "plan.json").read_text())
    inside = planner.plan(depth, obs.camera.intrinsics, obs.camera.pose)
    np.testing.assert_allclose(_table_grasp(via_cli), inside.grasp.table, atol=1e-4)
    w = via_cli["grasp"]["world"]
    np.testing.assert_allclose([w["x"], w["y"], w["z"], w["phi"]], inside.grasp.world, atol=1e-4)
    np.testing.assert_allclose(via_cli["grasp"]["action"], inside.grasp.action, atol=1e-4)
    assert via_cli["grasp"]["q_t"] == pytest.approx(inside.grasp.q_t, abs=1e-4)
    assert len(via_cli["alternatives"]) == 3 and set(via_cli["timing_ms"]) >= {"table", "grasp", "total"}
    assert (tmp_path / "plan.png").stat().st_size > 10_000
    # the world grasp lies on the hammer the simulator dropped
    from tognet.grasping.depth import prepare_depth

    scene = prepare_depth(obs.depth, obs.camera)
    uv, _ = obs.camera.project(inside.grasp.world[None, :3])
    u, v = np.rint(uv[0]).astype(int)
    assert scene.height[v - 10:v + 11, u - 10:u + 11].max() > 0.01  # within 2 cm
    # the frames agree: camera = camera_from_table . table, world = pose . camera
    g = inside.grasp
    cam = invert_pose(inside.table_from_camera) @ np.array([*g.table[:3], 1.0])
    np.testing.assert_allclose(g.camera_position, cam[:3], atol=1e-9)
    np.testing.assert_allclose((obs.camera.pose @ np.array([*g.camera_position, 1.0]))[:3], g.world[:3],
                               atol=1e-9)


def test_the_user_planner_is_the_evaluations_tognet_planner_on_the_same_view(planner, observation):
    """With the camera's own depth as the network's z (as the simulator's planners use), planning a
    simulator image gives exactly the evaluation's TOG-Net plan on that image in the table frame: both are
    tognet.policies' CEMGrasp on Q_T and PolicyActions' mean."""
    planners = pytest.importorskip("tognet.planning.methods")
    from types import SimpleNamespace

    from tognet.tasks import get_task

    obs = observation
    same = UserPlanner(TASK, planner.predictor, UserPlanConfig(network_camera_height=None))
    mine = same.plan(obs.depth, obs.camera.intrinsics, obs.camera.pose, seed=5)
    camera = Camera(obs.camera.intrinsics, plane_from_pose(obs.camera.pose).table_from_camera())
    view = SimpleNamespace(depth=obs.depth, camera=camera, task=TASK, seed=obs.seed, object_id=obs.object_id)
    theirs = planners.make_planner("TOG-Net", get_task(TASK), task_model=planner.predictor)(
        view, np.random.default_rng(5))
    np.testing.assert_allclose(mine.grasp.table, theirs.grasp, atol=1e-9)
    np.testing.assert_allclose(mine.grasp.action, theirs.action, atol=1e-6)


# --- the table plane --------------------------------------------------------------------------------------
@pytest.mark.parametrize("seed", [3, 11])
def test_without_the_camera_pose_the_grasp_is_within_5_mm_and_3_degrees(seed, planner, tools):
    """The same simulated image, float and rounded to millimetres, planned with and without its camera
    pose: the grasp planned on the fitted table lands within 5 mm and 3 degrees of the one planned with the
    pose; the fit itself is within 0.2 degrees and 2 mm, and reading any planned grasp in the fitted frame
    instead of the true one moves it by less than 5 mm and 3 degrees."""
    from tognet.sim import SimConfig, Simulator

    obs = Simulator(SimConfig(), TASK, tools["t_hammer"]).reset(seed)
    truth = plane_from_pose(obs.camera.pose)
    for depth in (obs.depth, (np.rint(obs.depth * 1000) / 1000).astype(np.float32)):  # as float, as PNG
        plan = planner.plan(depth, obs.camera.intrinsics)
        known = planner.plan(depth, obs.camera.intrinsics, obs.camera.pose)
        # the plan itself: the grasp planned without the pose, where it really is, against the one with it
        p, yaw, _ = _world_of(plan.grasp.table, plan.table_from_camera, obs.camera.pose)
        assert np.linalg.norm(p - known.grasp.world[:3]) < 0.005
        assert math.degrees(_angle(yaw, known.grasp.world[3])) < 3.0
        fit = plan.plane
        assert fit.fitted and fit.inliers > 0.3
        assert math.degrees(math.acos(min(1.0, float(fit.normal @ truth.normal)))) < 0.2
        assert abs(fit.offset - truth.offset) < 0.002
        for g in [plan.grasp, *plan.alternatives]:  # read in the fitted frame versus the true table frame
            p_fit, yaw_fit, axis = _world_of(g.table, fit.table_from_camera(), obs.camera.pose)
            p_true, yaw_true, _ = _world_of(g.table, truth.table_from_camera(), obs.camera.pose)
            assert np.linalg.norm(p_fit - p_true) < 0.005
            assert math.degrees(_angle(yaw_fit, yaw_true)) < 3.0 and abs(axis[2]) < math.sin(math.radians(3))
    without = planner.plan(obs.depth, obs.camera.intrinsics)
    assert without.world_from_camera is None and without.grasp.world is None


SENSORS = {
    "realsense_d435": CameraIntrinsics(width=640, height=480, fx=615.0, fy=615.0, cx=320.3, cy=238.9),
    "azure_kinect": CameraIntrinsics(width=640, height=576, fx=504.0, fy=504.2, cx=322.6, cy=333.1),
    "kinect2": CameraIntrinsics.kinect2(),
}


def _aimed(intrinsics, height, tilt, yaw):
    """A camera ``height`` m above the table, tilted (about its x, y axes) and yawed, aimed at the origin."""
    cam = tilted_camera(height, yaw=yaw, tilt=tilt, intrinsics=intrinsics)
    d = cam.pose[:3, :3] @ np.array([0.0, 0.0, 1.0])
    hit = cam.position - cam.position[2] / d[2] * d
    return Camera(intrinsics, make_pose(cam.pose[:3, :3], cam.position - np.array([hit[0], hit[1], 0.0])))


@pytest.mark.parametrize(("sensor", "height", "tilt", "yaw"), [
    ("realsense_d435", 0.5, (math.radians(30), 0.0), 0.4),
    ("azure_kinect", 1.0, (math.radians(-18), math.radians(22)), 2.2),
    ("kinect2", 1.5, (0.0, math.radians(-25)), -1.3),
])
def test_tilted_rolled_cameras_of_other_sensors_at_half_to_one_and_a_half_metres(sensor, height, tilt, yaw,
                                                                                 planner):
    """30 degrees from vertical at most, rolled about the axis (yaw), 0.5-1.5 m, other image sizes, 3 % holes
    (zeros and NaN): the table is found, the grasp lands on the tool, in the right place of the true frame."""
    camera = _aimed(SENSORS[sensor], height, tilt, yaw)
    depth = render_depth(camera, t_shape(0.02, -0.01, yaw=0.7))
    rng = np.random.default_rng(0)
    holes = rng.random(depth.shape) < 0.03
    depth[holes & (rng.random(depth.shape) < 0.5)] = 0.0
    depth[holes & ~(depth == 0.0)] = np.nan
    truth = plane_from_pose(camera.pose)
    plan = planner.plan(depth, camera.intrinsics)
    assert abs(plan.plane.tilt - truth.tilt) < 0.3 and abs(plan.plane.offset - truth.offset) < 0.003
    expected_tilt = math.degrees(math.acos(math.cos(tilt[0]) * math.cos(tilt[1])))
    assert truth.tilt == pytest.approx(expected_tilt, abs=0.01)
    p, _, _ = _world_of(plan.grasp.table, plan.table_from_camera, camera.pose)
    assert 0.0 < p[2] < 0.04
    # on the T shape (its bars span about 0.25 m x 0.14 m around (0.02, -0.01))
    above = render_depth(Camera.looking_down(CameraIntrinsics.kinect2(), [p[0], p[1], 0.7]),
                         t_shape(0.02, -0.01, yaw=0.7))
    assert 0.7 - np.nanmin(above[201:222, 245:266]) > 0.005  # within 2 cm of the grasp centre
    assert plan.objects[0]["area_cm2"] > 50 and not any("objects on the table" in w for w in plan.warnings)
    with_pose = planner.plan(depth, camera.intrinsics, camera.pose)
    assert with_pose.grasp.world is not None and 0.0 < with_pose.grasp.world[2] < 0.04


def test_several_objects_plan_on_the_largest_and_say_so(planner):
    camera = Camera.looking_down(CameraIntrinsics.kinect2(), [0.0, 0.0, 0.8])
    shapes = [*t_shape(0.1, 0.0, yaw=0.2), Box.on_table(-0.2, 0.1, (0.04, 0.04, 0.03)),
              Box.on_table(-0.15, -0.15, (0.05, 0.03, 0.02))]
    plan = planner.plan(render_depth(camera, shapes), camera.intrinsics, camera.pose)
    assert len(plan.objects) == 3
    assert any("3 objects on the table" in w and "planning on #0, the only one near the image's centre" in w
               for w in plan.warnings)
    assert plan.object["index"] == 0 and "of the 3 objects" in plan.object["why"]
    for g in [plan.grasp, *plan.alternatives]:
        assert np.hypot(g.world[0] - 0.1, g.world[1]) < 0.2  # on the T, not on a box


def test_the_one_call_api_and_a_low_score_warning(checkpoints, observation):
    import tognet

    obs = observation
    plan = tognet.plan(obs.depth, load_intrinsics(obs.camera.intrinsics), task=TASK,
                       checkpoint=checkpoints[TASK], config=UserPlanConfig(low_score=1.0), top=1,
                       reference=(0.3, -0.1, 0.045), camera_pose=obs.camera.pose)
    assert len(plan.alternatives) == 1
    assert any("low confidence: the plan's score" in w and "below the low_score 1" in w
               for w in plan.warnings)
    from tognet.tasks import get_task

    cfg = get_task(TASK).config
    np.testing.assert_allclose(plan.grasp.start_position,
                               np.array([0.3, -0.1, 0.045]) + cfg.nominal_offset + plan.grasp.action[:3])
    assert plan.grasp.start_yaw == pytest.approx(cfg.nominal_yaw + plan.grasp.action[3])
    assert np.all(plan.grasp.action >= get_task(TASK).action_low - 1e-9)
    again = tognet.plan(obs.depth, obs.camera.intrinsics, task=TASK, checkpoint=checkpoints[TASK],
                        config=UserPlanConfig(low_score=1.0), top=1, camera_pose=obs.camera.pose)
    np.testing.assert_array_equal(again.grasp.table, plan.grasp.table)  # seeded: reproducible


# --- the depth image's scale and the reference point -----------------------------------------------------
def _png(path, height, per_metre=1000, focal=365.0):
    """A 16-bit PNG of a T on a table ``height`` m below a camera looking down, in 1 / ``per_metre`` m."""
    from PIL import Image

    k = CameraIntrinsics(512, 424, focal, focal, 255.5, 211.5)
    depth = render_depth(Camera.looking_down(k, [0.0, 0.0, height]), t_shape(0.0, 0.0, yaw=0.3))
    Image.fromarray(np.rint(per_metre * np.nan_to_num(depth)).astype(np.uint16)).save(path)
    return path, k


@pytest.mark.parametrize("height", [0.4, 0.8, 1.2])
def test_a_millimetre_png_of_a_table_0_4_to_1_2_m_away_has_no_scale_warning(height, planner, tmp_path):
    path, k = _png(tmp_path / "d.png", height)
    plan = planner.plan(path, k)
    assert plan.plane.offset == pytest.approx(height, abs=0.01)
    assert not [w for w in plan.warnings if "(the median depth;" in w], plan.warnings


def test_a_png_of_doubtful_scale_warns_or_fails_naming_the_unit_it_looks_like(planner, tmp_path):
    far, k = _png(tmp_path / "far.png", 2.8, focal=1500.0)  # millimetres, but 2.8 m away reads like 0.1 mm
    plan = planner.plan(far, k)
    assert [w for w in plan.warnings if "the table is 2.80 m from the camera" in w
            and "if the values are 0.1 mm (the table 0.28 m away), divide by 10 to millimetres" in w]
    tenth, k = _png(tmp_path / "tenth.png", 0.4, per_metre=10_000)  # reads as 4 m: accepted, then fails
    with pytest.raises(Exception, match=r"scale may be why: .*tenth.png: the table is 4.00 m .* if the "
                       r"values are 0.1 mm \(the table 0.40 m away\), divide by 10 to millimetres"):
        planner.plan(tenth, k)
    assert UserPlanner.read_inputs(tenth, k)[0] is not None  # a warning, not an error, at the read


@pytest.mark.parametrize("task", ["sweeping", "hammering", "pulling"])
def test_the_tasks_reference_points_pass_the_limits_and_far_ones_do_not(task, observation):
    from tognet.planning.limits import InputLimits, check_reference, footprint
    from tognet.tasks import get_task

    cam = observation.camera  # the simulator's camera: world frame, z = 0 the table top
    box = footprint(cam.deproject(observation.depth)[::4, ::4].reshape(-1, 3))
    t, rng = get_task(task), np.random.default_rng(0)
    limits = InputLimits()
    for _ in range(200):
        ref = t.reference(t.sample_layout(rng))
        check_reference(ref, ref, box, "world", limits)
    for far, what in (((3.0, 0.0, 0.0), "from the table the image shows"), ((0.2, 0.0, -0.1), "below"),
                      ((0.2, 0.0, 0.8), "above")):
        with pytest.raises(ValueError, match=what):
            check_reference(np.array(far), np.array(far), box, "world", limits)


# --- bad inputs: one clear line each, nothing written -------------------------------------------------------
@pytest.fixture(scope="module")
def scene_files(tmp_path_factory, observation):
    root = tmp_path_factory.mktemp("scene")
    obs = observation
    return {"depth": save_depth_png(root / "d.png", obs.depth),
            "intr": save_intrinsics(root / "k.json", obs.camera.intrinsics),
            "pose": save_camera_pose(root / "pose.json", obs.camera.pose), "obs": obs, "root": root}


def _bad_case(case, tmp, files, checkpoints):
    """(args replacing the defaults, expected message) for one bad input."""
    obs = files["obs"]
    k = obs.camera.intrinsics
    if case == "shape":
        np.save(tmp / "d.npy", np.ones((*k.shape, 3), np.float32))
        return {"--depth": tmp / "d.npy"}, "must be 2-D (height, width), got shape (424, 512, 3)"
    if case == "dtype":
        np.save(tmp / "d.npy", np.ones(k.shape, bool))
        return {"--depth": tmp / "d.npy"}, "must be numeric, got dtype bool"
    if case == "millimetres_as_metres":
        np.save(tmp / "d.npy", (obs.depth * 1000).astype(np.float32))
        return {"--depth": tmp / "d.npy"}, "the values look like millimetres"
    if case == "metres_as_millimetres":
        save_depth_png(tmp / "d.png", obs.depth / 1000)  # metres written into a 16-bit PNG: 0 or 1
        return {"--depth": tmp / "d.png"}, ("the values look like metres (the table would be 1.00 m away): "
                                            "multiply by 1000")
    if case == "all_nan":
        np.save(tmp / "d.npy", np.full(k.shape, np.nan, np.float32))
        return {"--depth": tmp / "d.npy"}, "no valid pixels"
    if case == "empty":
        np.save(tmp / "d.npy", np.zeros((0, 0), np.float32))
        return {"--depth": tmp / "d.npy"}, "the depth image is empty"
    if case == "intrinsics_size":
        save_intrinsics(tmp / "k.json", CameraIntrinsics(640, 480, 615.0, 615.0, 320.0, 240.0))
        return {"--intrinsics": tmp / "k.json"}, "pixels but the intrinsics are for 640 x 480"
    if case == "intrinsics_transposed":
        save_intrinsics(tmp / "k.json", CameraIntrinsics(424, 512, 365.0, 365.0, 211.5, 255.5))
        return {"--intrinsics": tmp / "k.json"}, "transposed, or width and height are swapped"
    if case == "intrinsics_key":
        (tmp / "k.json").write_text('{"width": 512, "height": 424, "fx": 365, "fy": 365, "cx": 255.5}')
        return {"--intrinsics": tmp / "k.json"}, "missing cy"
    if case == "pose_below_table":
        save_camera_pose(tmp / "p.json", np.diag([1.0, -1.0, -1.0, 1.0]) @ obs.camera.pose)
        return {"--camera-pose": tmp / "p.json"}, "not above the table top"
    if case == "pose_not_the_images_table":
        pose = obs.camera.pose.copy()
        pose[2, 3] += 0.1  # the table 10 cm further than the image shows it
        save_camera_pose(tmp / "p.json", pose)
        return {"--camera-pose": tmp / "p.json"}, "the camera pose does not match the image"
    if case == "pose_not_a_rotation":
        pose = obs.camera.pose.copy()
        pose[:3, :3] *= 1000.0
        save_camera_pose(tmp / "p.json", pose)
        return {"--camera-pose": tmp / "p.json"}, "is not a rotation"
    if case == "no_object":
        camera = Camera.looking_down(k, [0.0, 0.0, 0.7])
        np.save(tmp / "d.npy", render_depth(camera, []))
        return {"--depth": tmp / "d.npy", "--camera-pose": None}, "no object on the table"
    if case == "other_task":
        return {"--checkpoint": checkpoints["sweeping"]}, "is a sweeping model; planning for hammering needs"
    if case == "garbage_checkpoint":
        (tmp / "model.pt").write_bytes(np.random.default_rng(0).bytes(5000))
        return {"--checkpoint": tmp / "model.pt"}, "not a readable checkpoint"
    if case == "garbage_npy":
        (tmp / "d.npy").write_bytes(np.random.default_rng(0).bytes(5000))
        return {"--depth": tmp / "d.npy"}, "not a .npy file"
    if case == "unknown_task":
        return {"--task": "sweep"}, "unknown --task 'sweep'"
    raise AssertionError(case)


BAD = ["shape", "dtype", "millimetres_as_metres", "metres_as_millimetres", "all_nan", "empty",
       "intrinsics_size", "intrinsics_transposed", "intrinsics_key", "pose_below_table",
       "pose_not_the_images_table", "pose_not_a_rotation", "no_object",
       "other_task", "garbage_checkpoint", "garbage_npy", "unknown_task"]


@pytest.mark.parametrize("case", BAD)
def test_every_bad_input_gets_one_clear_line_and_nothing_is_written(case, tmp_path, scene_files, checkpoints):
    args = {"--depth": scene_files["depth"], "--intrinsics": scene_files["intr"],
            "--camera-pose": scene_files["pose"], "--task": TASK, "--checkpoint": checkpoints[TASK]}
    changes, message = _bad_case(case, tmp_path, scene_files, checkpoints)
    args.update(changes)
    out = tmp_path / "out"
    argv = [x for k, v in args.items() if v is not None for x in (k, v)]
    result = _cli("plan", *argv, "--out", out / "plan.json", "--overlay", out / "plan.png")
    assert result.exit_code == 2, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and message in lines[0], result.output
    assert "Traceback" not in result.output and not out.exists()


def test_bad_output_paths_are_refused_before_any_work(tmp_path, scene_files, checkpoints):
    base = ["plan", "--depth", scene_files["depth"], "--intrinsics", scene_files["intr"], "--task", TASK,
            "--checkpoint", checkpoints[TASK]]
    for extra, message in ((["--out", tmp_path / "plan.txt"], "--out must name a .json file"),
                           (["--overlay", tmp_path], "is a folder"),
                           (["--reference", "0", "nan", "0"], "--reference takes 3 finite numbers")):
        result = _cli(*base, *extra)
        assert result.exit_code == 2 and message in result.output, result.output


def test_the_intrinsics_file_of_the_readme_and_its_variants(tmp_path):
    from pathlib import Path

    from tognet.planning.camera import CameraFileError

    root = Path(__file__).resolve().parents[1]
    k = load_intrinsics(root / "examples" / "intrinsics_realsense_d435.json")
    assert k == SENSORS["realsense_d435"]
    example = json.loads((root / "examples" / "intrinsics_realsense_d435.json").read_text())
    assert json.dumps(example) in (root / "README.md").read_text()  # the README shows the example file
    librealsense = {"width": 640, "height": 480, "ppx": 320.3, "ppy": 238.9, "fx": 615.0, "fy": 615.0,
                    "model": "distortion.inverse_brown_conrady", "coeffs": [0, 0, 0, 0, 0]}
    assert load_intrinsics(librealsense) == k
    assert load_intrinsics({"intrinsics": librealsense, "pose": np.eye(4).tolist()}) == k
    for change, message in (({"coeffs": [0.1, 0, 0, 0, 0]}, "non-zero distortion coefficients"),
                            ({"f": 615.0}, "unknown key 'f'"), ({"width": 640.5}, "positive whole number"),
                            ({"fx": -1.0}, "fx and fy must be positive"), ({"ppx": 900.0}, "outside the")):
        with pytest.raises(CameraFileError, match=message):
            load_intrinsics({**librealsense, **change})

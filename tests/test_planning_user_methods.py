"""One planning path (issue 30): a user's depth image is planned by the evaluation's own planners, with any
method a robot can run; the plan names its method and models, scores itself the method's way, and warns
by a threshold calibrated for that method and task."""

import ast
import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from typer.testing import CliRunner

from tognet.cli import app
from tognet.geometry import Camera
from tognet.models import MODELS_DIR, default_checkpoint
from tognet.planning.camera import save_camera_pose, save_depth_png, save_intrinsics
from tognet.planning.confidence import file_digest, low_confidence, threshold
from tognet.planning.methods import BEST_FIRST, METHOD_TABLE, NEEDS, make_planner
from tognet.planning.table import plane_from_pose
from tognet.planning.user import PlanInputError, UserPlanConfig, UserPlanner
from tognet.tasks import TASK_NAMES, get_task

TASK = "hammering"
SHIPPED = {"grasp": "grasping", "task": TASK, "search": f"{TASK}_search"}


@pytest.fixture(scope="module")
def observation(hammer_sim):
    return hammer_sim.reset(3)


@pytest.fixture(scope="module")
def models():
    from tognet.model.predict import TOGNetPredictor

    return {k: TOGNetPredictor.load(default_checkpoint(v), num_threads=1) for k, v in SHIPPED.items()}


def _cli(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


@pytest.mark.parametrize("method", BEST_FIRST)
def test_every_robot_method_is_the_evaluations_planner_on_the_same_view(method, observation, models):
    """With the image camera's own depth as the network's z (as the simulator's planners use), the user path
    plans the simulator's image exactly as the evaluation's planner of that method does on it (in the table
    frame): the same grasp and action, and the same own score."""
    obs = observation
    user = UserPlanner(TASK, config=UserPlanConfig(network_camera_height=None, top=0), method=method)
    mine = user.plan(obs.depth, obs.camera.intrinsics, obs.camera.pose, seed=5)
    camera = Camera(obs.camera.intrinsics, plane_from_pose(obs.camera.pose).table_from_camera())
    view = SimpleNamespace(depth=obs.depth, camera=camera, task=TASK, seed=obs.seed, object_id=obs.object_id)
    given = {f"{k}_model": models[k] for k in NEEDS[method]}
    theirs = make_planner(method, get_task(TASK), **given)(view, np.random.default_rng(5))
    np.testing.assert_allclose(mine.grasp.table, theirs.grasp, atol=1e-9)
    np.testing.assert_allclose(mine.grasp.action, theirs.action, atol=1e-6)
    assert mine.grasp.score == pytest.approx(theirs.own["score"], abs=1e-6)
    assert mine.method == method and set(mine.models) == set(NEEDS[method])


def test_the_default_is_the_action_search_on_every_task():
    for task in TASK_NAMES:
        planner = UserPlanner(task)
        assert planner.method == "TOG-Net+ActionSearch", task
        assert planner.paths == {"search": str(default_checkpoint(f"{task}_search"))}


def test_the_plan_json_names_the_method_its_models_and_its_scores(tmp_path, observation):
    obs = observation
    files = (save_depth_png(tmp_path / "d.png", obs.depth), save_intrinsics(tmp_path / "k.json",
             obs.camera.intrinsics), save_camera_pose(tmp_path / "pose.json", obs.camera.pose))
    result = _cli("plan", "--depth", files[0], "--intrinsics", files[1], "--camera-pose", files[2], "--task",
                  TASK, "--out", tmp_path / "plan.json", "--overlay", tmp_path / "plan.png")
    assert result.exit_code == 0, result.output
    plan = json.loads((tmp_path / "plan.json").read_text())
    assert plan["method"] == "TOG-Net+ActionSearch"
    assert plan["models"] == {"search": str(default_checkpoint(f"{TASK}_search"))}
    g = plan["grasp"]
    assert {"score", "q_g", "q_t_given_ga", "q_t"} <= set(g) and "q_t_given_g" not in g
    assert g["q_t"] == pytest.approx(g["q_g"] * g["q_t_given_ga"], abs=2e-4)
    assert len(plan["alternatives"]) == 3
    assert all(a["score"] <= g["score"] + 1e-9 for a in plan["alternatives"])  # ranked the method's way
    assert "TOG-Net+ActionSearch" in result.output and "Q_T|G,a" in result.output


def test_alternatives_are_distinct_grasps(observation):
    obs = observation
    plan = UserPlanner(TASK, method="TOG-Net", config=UserPlanConfig(top=4)).plan(
        obs.depth, obs.camera.intrinsics, obs.camera.pose)
    grasps = np.array([plan.grasp.table, *(a.table for a in plan.alternatives)])
    assert len(grasps) == 5
    for i in range(len(grasps)):
        for j in range(i):
            apart = np.linalg.norm(grasps[i, :3] - grasps[j, :3])
            turned = abs((grasps[i, 3] - grasps[j, 3] + np.pi) % (2 * np.pi) - np.pi)
            assert apart > 0.01 or turned > 0.3, (i, j)


@pytest.mark.parametrize("args, expect", [
    (["--method", "Oracle"], "needs the simulator"),
    (["--method", "TOG-Net grasp + Oracle motion"], "needs the simulator"),
    (["--method", "TOG-Nett"], "unknown method 'tog-nett'"),
    (["--method", "TOG-Net", "--checkpoint", MODELS_DIR / f"{TASK}_search.pt"],
     "action-search model (task_head='action'); tog-net needs a task's tog-net model"),
    (["--method", "TOG-Net+ActionSearch", "--checkpoint", MODELS_DIR / f"{TASK}.pt"],
     "is a task's tog-net model; tog-net+actionsearch needs a task's action-search model"),
    (["--checkpoint", MODELS_DIR / "grasping.pt"], "--method task_agn+trained or task_agn+random"),
])
def test_methods_that_cannot_plan_and_models_of_another_kind_are_refused(args, expect, tmp_path, observation):
    obs = observation
    d = save_depth_png(tmp_path / "d.png", obs.depth)
    k = save_intrinsics(tmp_path / "k.json", obs.camera.intrinsics)
    result = _cli("plan", "--depth", d, "--intrinsics", k, "--task", TASK, "--out", tmp_path / "p.json",
                  *args)
    assert result.exit_code == 2, result.output
    lines = [line for line in result.output.strip().splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: ") and expect in lines[0].lower(), result.output
    assert not (tmp_path / "p.json").exists()


def test_a_checkpoint_picks_the_method_of_its_kind(observation):
    search = UserPlanner(TASK, MODELS_DIR / f"{TASK}_search.pt")
    task = UserPlanner(TASK, MODELS_DIR / f"{TASK}.pt")
    agn = UserPlanner(TASK, MODELS_DIR / "grasping.pt", method="Task_Agn+Trained")
    assert (search.method, task.method, agn.method) == ("TOG-Net+ActionSearch", "TOG-Net", "Task_Agn+Trained")
    assert agn.paths == {"grasp": str(MODELS_DIR / "grasping.pt"), "task": str(default_checkpoint(TASK))}
    with pytest.raises(PlanInputError, match="is a sweeping model"):
        UserPlanner(TASK, MODELS_DIR / "sweeping_search.pt")


def test_user_py_builds_views_and_searches_nothing():
    """The user path holds no search, action or crop code of its own: it imports no policy but the view,
    and names no CEM, NMS ranking, action search or crop extraction."""
    source = (Path(__file__).parents[1] / "tognet" / "planning" / "user.py").read_text()
    tree = ast.parse(source)
    imported = {a.name for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)
                for a in n.names if (n.module or "").startswith("tognet.policies")}
    assert imported <= {"PolicyConfig", "SceneView"}, imported
    names = {n.id for n in ast.walk(tree) if isinstance(n, ast.Name)} | {
        n.attr for n in ast.walk(tree) if isinstance(n, ast.Attribute)}
    banned = {"cem", "CEMGrasp", "PolicyActions", "ActionSearchActions", "extract_crops", "nms", "predict",
              "encode", "score_actions"}
    assert not names & banned, names & banned


# --- the low-confidence threshold ---------------------------------------------------------------------------
def _calibration(tmp_path, warn_below, digest):
    path = tmp_path / "confidence.json"
    path.write_text(json.dumps({"models": {f"{TASK}_search": digest}, "thresholds": {TASK: {
        "TOG-Net+ActionSearch": {"warn_below": warn_below, "uses": ["search"], "scenes": 100, "success": 0.6,
                                 "below": {"n": 20, "success": 0.2}, "above": {"n": 80, "success": 0.7}}}}}))
    return path


def test_the_calibrated_threshold_holds_only_for_its_models(tmp_path, monkeypatch):
    import tognet.planning.confidence as confidence

    shipped = str(MODELS_DIR / f"{TASK}_search.pt")
    path = _calibration(tmp_path, 0.4, file_digest(shipped))
    monkeypatch.setattr(confidence, "CONFIDENCE_FILE", path)
    assert threshold(TASK, "TOG-Net+ActionSearch", {"search": shipped}, path)["warn_below"] == 0.4
    other = str(MODELS_DIR / f"{TASK}.pt")
    assert threshold(TASK, "TOG-Net+ActionSearch", {"search": other}, path) is None  # another model
    assert threshold(TASK, "TOG-Net", {"task": other}, path) is None  # no entry
    held, line = low_confidence(TASK, "TOG-Net+ActionSearch", {"search": shipped}, 0.3)
    assert held["warn_below"] == 0.4 and "below 0.400" in line and "20 % of held-out scenes" in line
    assert low_confidence(TASK, "TOG-Net+ActionSearch", {"search": shipped}, 0.5)[1] is None
    _, line = low_confidence(TASK, "TOG-Net+ActionSearch", {"search": other}, 0.0)
    assert line is None  # not calibrated for that model: no warning
    _, line = low_confidence(TASK, "TOG-Net+ActionSearch", {"search": other}, 0.2, own=0.25)
    assert "below the low_score 0.25" in line
    always = _calibration(tmp_path, "always", file_digest(shipped))
    monkeypatch.setattr(confidence, "CONFIDENCE_FILE", always)
    assert "never more often than not" in low_confidence(TASK, "TOG-Net+ActionSearch", {"search": shipped},
                                                         0.99)[1]


#: Robot methods whose calibration has not been run yet (TOG-Net+Twin, added 2026-12-08: its run did not fit
#: in that session); they give no low-confidence warning. Once calibrated, the check below fails: remove it.
NOT_YET_CALIBRATED = ("TOG-Net+Twin",)


def test_the_shipped_calibration_covers_every_robot_method_and_task():
    table = json.loads((MODELS_DIR / "confidence.json").read_text())
    for task in TASK_NAMES:
        for row in METHOD_TABLE:
            if row.uses_sim or row.name in NOT_YET_CALIBRATED:
                assert row.name not in table["thresholds"][task]
                continue
            entry = table["thresholds"][task][row.name]
            assert entry["scenes"] >= 100 and sorted(entry["uses"]) == sorted(row.needs)
            paths = {k: str(default_checkpoint(SHIPPED[k] if k == "grasp" else
                                               (task if k == "task" else f"{task}_search")))
                     for k in row.needs}
            assert threshold(task, row.name, paths) is not None, (task, row.name)  # digests match

"""End to end across packages: objects -> collection (simulator, grasp candidates, shards) -> training ->
predictor -> CEM -> execution. Small, but every hand-off between packages is the real one."""

import json
from pathlib import Path

import numpy as np
import pytest

from tognet.collect.config import CollectConfig, RoundConfig
from tognet.collect.rounds import collect_round
from tognet.data import read_dataset
from tognet.geometry import Grasp
from tognet.grasping import AntipodalConfig, CEMConfig, CropConfig, cem, prepare_depth, sample_antipodal
from tognet.jobs.workers import LocalExecutor
from tognet.objects import generate_set
from tognet.sim import SimConfig, Simulator
from tognet.tasks import get_task


@pytest.fixture(scope="module")
def collected(tmp_path_factory):
    """A round-1 sweeping collection on two primitive objects (tognet.collect's own glue), as shards."""
    root = tmp_path_factory.mktemp("pipeline")
    records = generate_set("primitive", "train", 2, root / "objects")
    summary = collect_round("sweeping", 1, records, RoundConfig(episodes=10, policy="nms_uniform"),
                            CollectConfig(trials_per_scene=5, scenes_per_job=1), root / "data",
                            executor=LocalExecutor(0), progress=False, log=lambda _m: None)
    return root, records, summary


def test_crops_and_depths_are_finite_and_shaped(collected):
    root, _, summary = collected
    episodes = read_dataset([root / "data"])
    assert len(episodes) == summary["valid"] == 10
    assert episodes.crop.shape == (10, 64, 64)
    assert np.all(np.isfinite(episodes.crop)) and np.all(np.isfinite(episodes.z))
    # The gripper depth is a camera-frame depth of a point near the table top under a ~1 m high camera.
    assert np.all((episodes.z > 0.3) & (episodes.z < 1.5))
    assert int(episodes.task_success.sum()) == summary["task_success"]
    assert np.all(episodes.task_success <= episodes.grasp_success)
    # the round's configs travel with the data: the crops' CropConfig is what training records
    saved = json.loads((root / "data" / "configs" / "crop.json").read_text())
    assert saved["extent"] == CropConfig().extent


def test_train_predict_and_plan(collected):
    from tognet.model.config import TrainConfig
    from tognet.model.predict import TOGNetPredictor
    from tognet.model.train import train

    root, records, _ = collected
    out = root / "model"
    train([root / "data"], "sweeping", out, TrainConfig(epochs=2, batch_size=4, val_fraction=0.5),
          progress=False, log=lambda _msg: None)
    checkpoint = next(p for p in (out / "best.pt", out / "last.pt") if Path(p).is_file())
    predictor = TOGNetPredictor.load(checkpoint)

    sim = Simulator(SimConfig(), "sweeping", records[0])
    obs = sim.reset(seed=11)
    scene = prepare_depth(obs.depth, obs.camera)
    rng = np.random.default_rng(1)
    cands = sample_antipodal(scene, None, AntipodalConfig(), rng)
    pred = predictor.predict_grasps(scene, cands.grasps)
    assert pred.q_t.shape == (len(cands),)
    assert np.all((pred.q_t >= 0) & (pred.q_t <= pred.q_g + 1e-6))
    score = predictor.grasp_score_fn(scene, "task")
    result = cem(score, cands.grasps, CEMConfig(), rng)
    assert result.best_score >= float(np.max(pred.q_t)) - 1e-5
    action = predictor.predict_grasps(scene, result.best[None]).action_mean[0]
    task = get_task("sweeping")
    action = np.clip(action, task.action_low, task.action_high)
    trial = sim.execute(Grasp.from_array(result.best), action, seed=0)
    assert trial.valid

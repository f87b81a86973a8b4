"""End to end across packages: objects -> simulator -> grasp candidates -> episode shards -> training ->
predictor -> CEM -> execution. Small, but every hand-off between packages is the real one."""

from pathlib import Path

import numpy as np
import pytest

from tognet.data import ShardWriter, read_dataset
from tognet.geometry import Grasp
from tognet.grasping import (
    AntipodalConfig,
    CEMConfig,
    CropConfig,
    NMSConfig,
    cem,
    extract_crops,
    grasp_depths,
    nms,
    prepare_depth,
    sample_antipodal,
)
from tognet.objects import generate_set
from tognet.sim import SimConfig, Simulator
from tognet.tasks import get_task


@pytest.fixture(scope="module")
def collected(tmp_path_factory):
    """A few sweeping episodes on two primitive objects, written as shards."""
    root = tmp_path_factory.mktemp("pipeline")
    records = generate_set("primitive", "train", 2, root / "objects")
    task = get_task("sweeping")
    rng = np.random.default_rng(0)
    data = root / "data"
    labels = []
    with ShardWriter(data, "sweeping", meta={"round": 1, "policy": "nms_random"}, shard_size=8,
                     configs={"crop": CropConfig()}) as writer:
        for record in records:
            sim = Simulator(SimConfig(), "sweeping", record)
            obs = sim.reset(seed=3)
            scene = prepare_depth(obs.depth, obs.camera)
            cands = sample_antipodal(scene, None, AntipodalConfig(), rng)
            assert len(cands) > 0
            keep = nms(cands.grasps, cands.quality, NMSConfig())[:5]
            grasps = cands.grasps[keep]
            crops = extract_crops(scene, None, grasps, CropConfig())
            z = grasp_depths(scene.camera, grasps)
            for i, g in enumerate(grasps):
                action = task.random_action(rng)
                result = sim.execute(Grasp.from_array(g), action, seed=i)
                labels.append((result.grasp_success, result.task_success))
                writer.add(crop=crops[i], z=np.float32(z[i]), grasp=g.astype(np.float32),
                           action=action.astype(np.float32), grasp_success=result.grasp_success,
                           task_success=result.task_success, valid=result.valid,
                           failure=result.failure, object_id=record.object_id, scene_seed=3, trial=i)
    return root, records, labels


def test_crops_and_depths_are_finite_and_shaped(collected):
    root, _, labels = collected
    episodes = read_dataset([root / "data"])
    assert len(episodes) == len(labels) == 10
    assert episodes.crop.shape == (10, 64, 64)
    assert np.all(np.isfinite(episodes.crop)) and np.all(np.isfinite(episodes.z))
    # The gripper depth is a camera-frame depth of a point near the table top under a ~1 m high camera.
    assert np.all((episodes.z > 0.3) & (episodes.z < 1.5))
    stored = [(bool(g), bool(t)) for g, t in zip(episodes.grasp_success, episodes.task_success, strict=True)]
    assert sorted(stored) == sorted(labels)


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

"""Smoke run of the whole pipe on real simulated episodes: objects -> simulator -> antipodal candidates ->
NMS -> crops -> uniform random actions -> labels -> shards (``tognet.collect``'s round 1, in this process) ->
``tognet train`` (a few epochs, CPU).

    .venv/bin/python benchmarks/smoke_real_training.py [--task sweeping] [--objects 20] [--scenes 1]
        [--grasps 10] [--epochs 4] [--out DIR]

Prints label rates, failure reasons, array checks (shapes, units, NaNs) and the validation metrics. With
little data the metrics are weak; the point is that every stage fits the next. Writes into ``--out`` (a
temporary folder by default); never commit the dataset it writes.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np

from tognet.collect.config import CollectConfig, RoundConfig
from tognet.collect.rounds import collect_round
from tognet.data.episodes import read_dataset
from tognet.data.format import FAILURE_CODES, FIELDS
from tognet.geometry import Grasp
from tognet.grasping import AntipodalConfig, prepare_depth, sample_antipodal
from tognet.jobs.workers import LocalExecutor
from tognet.model.config import TrainConfig
from tognet.model.train import train
from tognet.objects import generate_set
from tognet.sim import SimConfig, Simulator


def collect(task_name: str, objects: Path, data: Path, n_objects: int, scenes: int, grasps: int,
            seed: int) -> dict:
    """A round-1 collection (NMS grasps, uniform actions) through tognet.collect, in this process."""
    records = generate_set("primitive", "train", n_objects, objects)
    cfg = CollectConfig(trials_per_scene=grasps, scenes_per_job=scenes, seed=seed)
    t0 = time.perf_counter()
    rc = RoundConfig(episodes=n_objects * scenes * grasps)
    summary = collect_round(task_name, 1, records, rc, cfg, data, executor=LocalExecutor(0), progress=False,
                            log=lambda _m: None)
    return {"seconds": time.perf_counter() - t0, "failures": summary["failures"], "errors": summary["errors"]}


def check_arrays(data: Path) -> dict:
    ep = read_dataset([data], keep_invalid=True)
    assert ep.crop.shape[1:] == (64, 64) and ep.crop.dtype == FIELDS["crop"][0]  # stored as float16
    for name in ("crop", "z", "grasp", "action"):
        assert np.all(np.isfinite(getattr(ep, name))), f"{name} has NaN/inf"
    assert set(np.unique(ep.grasp_success)) <= {0, 1} and set(np.unique(ep.task_success)) <= {0, 1}
    assert np.all(ep.task_success <= ep.grasp_success), "S_T = 1 without S_G = 1"
    assert set(np.unique(ep.failure)) <= set(FAILURE_CODES.values())
    ok = ep.valid.astype(bool)
    return {
        "episodes": len(ep), "valid": int(ok.sum()), "objects": int(len(np.unique(ep.object_id))),
        "grasp_success_rate": float(ep.grasp_success[ok].mean()),
        "task_success_rate": float(ep.task_success[ok].mean()),
        "task_given_grasp_rate": float(ep.task_success[ok & (ep.grasp_success > 0)].mean())
        if (ok & (ep.grasp_success > 0)).any() else None,
        "z_range_m": [float(ep.z.min()), float(ep.z.max())],
        "crop_range_m": [float(ep.crop.min()), float(ep.crop.max())],
        "grasp_z_range_m": [float(ep.grasp[:, 2].min()), float(ep.grasp[:, 2].max())],
        "action_min": ep.action.min(0).round(4).tolist(), "action_max": ep.action.max(0).round(4).tolist(),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--task", default="sweeping")
    ap.add_argument("--objects", type=int, default=20)
    ap.add_argument("--scenes", type=int, default=1, help="Scenes (resets) per object.")
    ap.add_argument("--grasps", type=int, default=10, help="NMS-kept grasps executed per scene.")
    ap.add_argument("--epochs", type=int, default=4)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=None, help="Work folder (default: a temporary one).")
    args = ap.parse_args()
    work = args.out or Path(tempfile.mkdtemp(prefix="tognet-smoke-"))
    data = work / "data"
    stats = collect(args.task, work / "objects", data, args.objects, args.scenes, args.grasps, args.seed)
    print(f"collected in {stats['seconds']:.0f} s; outcomes {stats['failures']}; skipped {stats['errors']}")
    print("data:", json.dumps(check_arrays(data)))
    cfg = TrainConfig(epochs=args.epochs, batch_size=64, val_fraction=0.2, patience=args.epochs)
    t0 = time.perf_counter()
    result = train([data], args.task, work / "run", cfg, progress=False)
    print(f"trained {result.epochs_run} epochs in {time.perf_counter() - t0:.0f} s -> {result.best_path}")
    last = result.history[-1]
    print("last epoch val:", json.dumps({k: last["val"].get(k) for k in ("count", "loss", "grasp", "task",
                                                                            "action")}))
    print("val metrics:", json.dumps(last["val"].get("metrics"), default=str))
    predict_on_new_scene(result.best_path, args.task, work / "objects", args.seed)


def predict_on_new_scene(checkpoint: Path, task_name: str, objects: Path, seed: int) -> None:
    """The planner's path on a fresh scene: candidates -> predict_grasps (the checkpoint's crops) -> best."""
    from tognet.model.predict import TOGNetPredictor

    predictor = TOGNetPredictor.load(checkpoint)
    print("checkpoint crop_config:", json.dumps(predictor.info.get("crop_config")))
    rec = generate_set("primitive", "test", 1, objects.parent / "test-objects")[0]
    sim = Simulator(SimConfig(), task_name, rec)
    obs = sim.reset(seed + 12345)
    scene = prepare_depth(obs.depth, obs.camera)
    cands = sample_antipodal(scene, None, AntipodalConfig(), np.random.default_rng(seed))
    predictor.predict_grasps(scene, cands.grasps)  # the first call of a TorchScript module is slow
    t0 = time.perf_counter()
    pred = predictor.predict_grasps(scene, cands.grasps)
    ms = 1e3 * (time.perf_counter() - t0)
    best = int(np.argmax(pred.q_t))
    assert np.all((pred.q_t >= 0) & (pred.q_t <= 1)) and np.all(np.isfinite(pred.action_mean))
    print(f"new scene ({rec.object_id}): {len(cands.grasps)} candidates scored in {ms:.1f} ms "
          "(crops + net, 2nd call); "
          f"Q_T range {pred.q_t.min():.3f}-{pred.q_t.max():.3f}; "
          f"best grasp {np.round(cands.grasps[best], 3)} action {np.round(pred.action_mean[best], 3)}")
    res = sim.execute(Grasp.from_array(cands.grasps[best]), pred.action_mean[best], seed=0)
    print(f"executed: S_G={int(res.grasp_success)} S_T={int(res.task_success)} ({res.failure.value})")


if __name__ == "__main__":
    main()

"""Before/after label agreement of the simulator on a fixed set of seeded episodes.

    .venv/bin/python benchmarks/label_agreement.py record OUT.json [--objects 16 --grasps 3]
    .venv/bin/python benchmarks/label_agreement.py compare OUT.json

``record`` generates PG-Primitive objects, resets one scene per object and task (seed = object index),
samples antipodal grasps on the depth image, keeps NMS modes and runs a few of them (both random
baseline actions, +-5 cm / +-pi/20, and uniform actions over the task's box), saving the grasps, the
actions, the settled object pose and the labels (S_G, S_T, validity, failure reason, in-hand pose).
``compare`` re-runs exactly the same grasps and actions with the current code (and, with ``--config``,
another simulator configuration) and prints how many
labels agree, per task, and how far the settled object and the in-hand pose moved. Use it to check that
a speed-up of the simulator leaves what the tasks measure unchanged.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from tognet.config import ConfigError
from tognet.geometry import Grasp
from tognet.grasping import AntipodalConfig, NMSConfig, nms, prepare_depth, sample_antipodal
from tognet.objects.generate import generate_set
from tognet.sim import SimConfig, Simulator
from tognet.tasks import TASK_NAMES

TASKS = TASK_NAMES  # every registered task


def _trial(sim: Simulator, grasp: list[float], action: list[float], seed: int) -> dict[str, Any]:
    res = sim.execute(Grasp.from_array(np.asarray(grasp)), np.asarray(action), seed)
    return {
        "grasp_success": bool(res.grasp_success),
        "task_success": bool(res.task_success),
        "valid": bool(res.valid),
        "failure": str(res.failure),
        "in_hand": res.info.get("in_hand"),
        "in_hand_start": res.info.get("in_hand_start"),
    }


def record(out: Path, n_objects: int, n_grasps: int, tmp: str, cfg: SimConfig) -> None:
    records = generate_set("primitive", "train", n_objects, Path(tmp) / "prim")
    episodes: list[dict[str, Any]] = []
    for task in TASKS:
        for k, rec in enumerate(records):
            rng = np.random.default_rng([k, 77])
            sim = Simulator(cfg, task, rec)
            obs = sim.reset(k)
            pos, _ = sim.object_pose()
            scene = prepare_depth(obs.depth, obs.camera)
            cands = sample_antipodal(scene, None, AntipodalConfig(), rng)
            if len(cands) == 0:
                continue
            keep = nms(cands.grasps, cands.quality, NMSConfig())
            for j, gi in enumerate(rng.permutation(keep)[:n_grasps]):
                grasp = [float(v) for v in cands.grasps[gi]]
                for kind in ("random", "uniform"):
                    assert sim.task is not None
                    a = sim.task.random_action(rng) if kind == "random" else sim.task.uniform_action(rng)
                    seed = 100 * j + (kind == "uniform")
                    ep = {
                        "task": task,
                        "object": rec.object_id,
                        "index": k,
                        "scene_seed": k,
                        "object_pos": pos.tolist(),
                        "grasp": grasp,
                        "action": [float(v) for v in a],
                        "seed": seed,
                    }
                    ep["labels"] = _trial(sim, grasp, ep["action"], seed)
                    episodes.append(ep)
    out.write_text(json.dumps({"objects": n_objects, "episodes": episodes}, indent=1))
    print(f"recorded {len(episodes)} episodes to {out}")


def compare(path: Path, tmp: str, cfg: SimConfig) -> None:
    saved = json.loads(path.read_text())
    records = generate_set("primitive", "train", saved["objects"], Path(tmp) / "prim")
    sims: dict[tuple[str, int], Simulator] = {}
    stats: dict[str, dict[str, Any]] = {
        t: {"n": 0, "sg": 0, "st": 0, "all": 0, "pose": [], "hand": [], "start": [], "flips": []}
        for t in dict.fromkeys(ep["task"] for ep in saved["episodes"])  # the tasks recorded
    }
    t0 = time.perf_counter()
    for ep in saved["episodes"]:
        key = (ep["task"], ep["index"])
        if key not in sims:
            sim = Simulator(cfg, ep["task"], records[ep["index"]])
            sim.reset(ep["scene_seed"])
            sims[key] = sim
        sim = sims[key]
        pos, _ = sim.object_pose()
        new = _trial(sim, ep["grasp"], ep["action"], ep["seed"])
        old = ep["labels"]
        s = stats[ep["task"]]
        s["n"] += 1
        s["sg"] += old["grasp_success"] == new["grasp_success"]
        s["st"] += old["task_success"] == new["task_success"]
        same = all(old[k] == new[k] for k in ("grasp_success", "task_success", "valid", "failure"))
        s["all"] += same
        if not same:
            s["flips"].append(
                f"{ep['object']} seed {ep['seed']}: {old['grasp_success']:d}{old['task_success']:d} "
                f"{old['failure']} -> {new['grasp_success']:d}{new['task_success']:d} {new['failure']}"
            )
        s["pose"].append(float(np.linalg.norm(pos - np.asarray(ep["object_pos"]))))
        if old["in_hand"] is not None and new["in_hand"] is not None:
            s["hand"].append(float(np.max(np.abs(np.asarray(old["in_hand"]) - np.asarray(new["in_hand"])))))
        if old.get("in_hand_start") is not None and new["in_hand_start"] is not None:
            change = np.abs(np.asarray(old["in_hand_start"]) - np.asarray(new["in_hand_start"]))
            s["start"].append(float(np.max(change)))
    for task, s in stats.items():
        n = max(s["n"], 1)
        hand = np.asarray(s["hand"]) if s["hand"] else np.zeros(1)
        start = np.asarray(s["start"]) if s["start"] else np.zeros(1)
        print(
            f"{task:<10} {s['n']} episodes: S_G agree {s['sg']}/{n}, S_T agree {s['st']}/{n}, "
            f"all labels + failure reason agree {s['all']}/{n} ({s['all'] / n:.0%}); settled object moved "
            f"median {1000 * np.median(s['pose']):.2f} mm (max {1000 * np.max(s['pose']):.2f}); in-hand pose "
            f"change after the hold median {np.median(hand):.4f}, max {np.max(hand):.4f}; at the start pose "
            f"median {np.median(start):.4f}, max {np.max(start):.4f} (m and rotation-matrix entries)"
        )
        for line in s["flips"]:
            print(f"    changed: {line}")
    print(f"({time.perf_counter() - t0:.0f} s)")


def _load_config(parser: argparse.ArgumentParser, path: Path | None) -> SimConfig:
    """The --config file's SimConfig (the defaults without one); a bad file ends with its message."""
    try:
        return SimConfig.load(path) if path else SimConfig()
    except ConfigError as exc:
        parser.error(str(exc))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("mode", choices=("record", "compare"), help="record labels, or compare with a record")
    parser.add_argument("path", type=Path, help="JSON file of the recorded episodes")
    parser.add_argument("--objects", type=int, default=16, help="PG-Primitive objects (record)")
    parser.add_argument("--grasps", type=int, default=3, help="NMS grasps per object (2 actions each)")
    parser.add_argument(
        "--config", type=Path, help="SimConfig JSON to record or replay under (e.g. another time step)"
    )
    args = parser.parse_args()
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    cfg = _load_config(parser, args.config)
    with tempfile.TemporaryDirectory() as tmp:
        if args.mode == "record":
            record(args.path, args.objects, args.grasps, tmp, cfg)
        else:
            compare(args.path, tmp, cfg)


if __name__ == "__main__":
    main()

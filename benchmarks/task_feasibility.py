"""Can generated objects do the tasks at all? Oracle search and round-1 success rates per object.

    .venv/bin/python benchmarks/task_feasibility.py --objects DIR [DIR ...] [--budget 300] [--modes 4]
    .venv/bin/python benchmarks/task_feasibility.py --objects DIR --candidates-only [--max-objects 300]

For each object (one scene per task): antipodal candidates on the depth image, NMS modes, a few modes
picked at random; for each mode BOTH jaw orientations (phi, phi + pi) are tried with the oracle's
hand-computed actions (tognet.sim.oracle: ground-truth geometry) and with uniformly random actions over
the task's action box (what round-1 self-supervision collects: an NMS mode, a random orientation, a
random action). Prints per kind and task: the fraction of objects with at least one success (oracle),
the oracle success rate per (grasp, action), and the round-1 rate (random action), over valid trials.
Stops taking new objects when the time budget (CPU seconds, per task) runs out.
``--candidates-only`` runs no trials: it counts the objects on whose depth image (one scene of the first
task) the sampler finds antipodal candidates, in all and per part variant (a generator profile's flat,
thin or tall parts, recorded in each object's extra["variants"]).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from tognet.geometry import Grasp
from tognet.grasping import AntipodalConfig, NMSConfig, nms, prepare_depth, sample_antipodal
from tognet.objects.record import load_catalog
from tognet.sim import SimConfig, Simulator
from tognet.sim.oracle import task_actions
from tognet.tasks import TASK_NAMES


def run(task: str, records: list, cfg: SimConfig, modes: int, randoms: int, budget: float) -> dict:
    cpu0 = time.process_time()
    per_obj = []
    for k, rec in enumerate(records):
        if time.process_time() - cpu0 > budget:
            break
        rng = np.random.default_rng(k)
        sim = Simulator(cfg, task, rec)
        obs = sim.reset(k)
        scene = prepare_depth(obs.depth, obs.camera)
        cands = sample_antipodal(scene, None, AntipodalConfig(), rng)
        if len(cands) == 0:
            per_obj.append({"id": rec.object_id, "grasps": 0, "oracle": [], "random": [], "grasp_ok": 0})
            continue
        keep = nms(cands.grasps, cands.quality, NMSConfig())
        pick = rng.permutation(keep)[:modes]
        oracle, rand, grasp_ok, n_g = [], [], 0, 0
        seed = 0
        for gi in pick:
            for flip in (0.0, np.pi):
                g = cands.grasps[gi].copy()
                g[3] = (g[3] + flip) % (2 * np.pi)
                grasp = Grasp.from_array(g)
                # A first trial shows how the tool hangs in the hand; the oracle aims with that.
                seed += 1
                probe = sim.execute(grasp, sim.task.uniform_action(rng), seed)
                n_g += 1
                grasp_ok += int(probe.grasp_success)
                if probe.valid:
                    rand.append(int(probe.task_success))
                if not probe.grasp_success:
                    oracle.append(0)  # the grasp itself fails (usually): counted once
                    continue
                in_hand = probe.info["in_hand"]
                acts = task_actions(sim, grasp, in_hand=in_hand)  # the task's oracle, default options
                for a in acts:
                    seed += 1
                    r = sim.execute(grasp, a, seed)
                    if r.valid:
                        oracle.append(int(r.task_success))
                for _ in range(randoms - 1):
                    seed += 1
                    r = sim.execute(grasp, sim.task.uniform_action(rng), seed)
                    if r.valid:
                        rand.append(int(r.task_success))
        per_obj.append(
            {
                "id": rec.object_id,
                "grasps": len(pick),
                "oracle": oracle,
                "random": rand,
                "grasp_ok": grasp_ok / max(1, n_g),
            }
        )
    return {"objects": per_obj, "cpu": time.process_time() - cpu0}


def candidate_counts(records: list, cfg: SimConfig, task: str) -> dict[str, list[int]]:
    """Per group (all, and each part variant ``A:name`` / ``B:name``): [objects with candidates, objects]."""
    groups: dict[str, list[int]] = {"all": [0, 0]}
    for k, rec in enumerate(records):
        obs = Simulator(cfg, task, rec).reset(k)
        cands = sample_antipodal(prepare_depth(obs.depth, obs.camera), None, AntipodalConfig(),
                                 np.random.default_rng(k))
        names = ["all"] + [f"{part}:{name or 'plain'}" for part, name in
                           sorted(rec.extra.get("variants", {}).items())]
        for name in names:
            count = groups.setdefault(name, [0, 0])
            count[0] += int(len(cands) > 0)
            count[1] += 1
    return groups


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--objects", nargs="+", required=True, help="object set folders (with catalog)")
    p.add_argument("--tasks", nargs="+", default=list(TASK_NAMES), help="tasks to measure")
    p.add_argument("--modes", type=int, default=4, help="NMS modes tried per object")
    p.add_argument(
        "--randoms",
        type=int,
        default=3,
        help="random actions per (mode, orientation), the first also probes the grasp",
    )
    p.add_argument("--budget", type=float, default=120.0, help="CPU seconds per (set, task)")
    p.add_argument("--max-objects", type=int, default=30, help="objects per set at most")
    p.add_argument("--verbose", action="store_true", help="one line per object")
    p.add_argument("--config", type=Path, default=None, help="SimConfig JSON (default: built-in)")
    p.add_argument("--candidates-only", action="store_true",
                   help="only count objects with antipodal candidates (no trials)")
    args = p.parse_args()
    cfg = SimConfig.load(args.config) if args.config else SimConfig()
    for folder in args.objects:
        records = load_catalog(Path(folder))[: args.max_objects]
        if args.candidates_only:
            groups = candidate_counts(records, cfg, args.tasks[0])
            text = ", ".join(f"{name} {n}/{total}" for name, (n, total) in sorted(groups.items()))
            print(f"{Path(folder).name}: objects with antipodal candidates: {text}", flush=True)
            continue
        for task in args.tasks:
            res = run(task, records, cfg, args.modes, args.randoms, args.budget)
            objs = res["objects"]
            feasible = sum(1 for o in objs if any(o["oracle"]))
            orc = [x for o in objs for x in o["oracle"]]
            rnd = [x for o in objs for x in o["random"]]
            grasp_ok = np.mean([o["grasp_ok"] for o in objs if o["grasps"]])
            if args.verbose:
                for o in objs:
                    print(
                        f"  {o['id']}: oracle {sum(o['oracle'])}/{len(o['oracle'])} random "
                        f"{sum(o['random'])}/{len(o['random'])} grasp {o['grasp_ok']:.2f}"
                    )
            print(
                f"{Path(folder).name:<6} {task:<10} objects {len(objs):>3}  "
                f"feasible (oracle) {feasible}/{len(objs)}"
                f" = {feasible / max(1, len(objs)):.0%}  oracle trials {sum(orc)}/{len(orc)}"
                f" = {sum(orc) / max(1, len(orc)):.1%}  NMS+random action {sum(rnd)}/{len(rnd)}"
                f" = {sum(rnd) / max(1, len(rnd)):.1%}  grasp success {grasp_ok:.0%}"
                f"  ({res['cpu']:.0f} cpu s)",
                flush=True,
            )


if __name__ == "__main__":
    main()

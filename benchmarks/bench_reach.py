"""Planning with an arm in the simulator (tognet.planning.reach): what the reach filter costs and drops, one
core.

    .venv/bin/python benchmarks/bench_reach.py [--scenes 6] [--objects 3] [--exact] [--base X Y Z YAW]

For each task (hammering, sweeping, pulling) and ``--objects`` fresh PG-Primitive test objects, ``--scenes``
scenes each; on every scene TOG-Net (the shipped model) and Antipodal+Random plan with the floating gripper,
the Sawyer and the Panda (each with its preset, at its default base or at ``--base``), from generators in
the same state, after one untimed plan each. Prints per arm and method: the median and p90 plan time and
the ratio of the medians to the floating gripper's (the same scenes); how many of the 200 candidates the
envelope dropped before scoring; how many plans were not the method's own choice (a grasp further down its
ranking); how many found nothing within reach (OutOfReach, by task and the step where most of its checked
grasps failed); how many were the floating gripper's own plan. ``--exact``: also every candidate's own
steps (approach, grasp, lift) through the arm's check, to say how many the arm truly cannot reach (slow:
up to a few tenths of a second a candidate out of reach). The machine is shared: read the load average
printed with the times.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from collections import Counter, defaultdict
from pathlib import Path

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", type=int, default=6)
    ap.add_argument("--objects", type=int, default=3)
    ap.add_argument("--tasks", nargs="+", default=["hammering", "sweeping", "pulling"])
    ap.add_argument("--exact", action="store_true", help="IK on every candidate's own steps too")
    ap.add_argument("--base", type=float, nargs=4, default=None, metavar=("X", "Y", "Z", "YAW"),
                    help="both arms' base (default: each arm's own)")
    args = ap.parse_args()

    import torch

    from tognet.model.predict import TOGNetPredictor
    from tognet.objects import generate_set
    from tognet.objects.record import load_catalog
    from tognet.planning import make_planner
    from tognet.planning.reach import OutOfReach, reach_of
    from tognet.sim import SimConfig, Simulator
    from tognet.sim.config import with_robot

    torch.set_num_threads(1)
    os.sched_setaffinity(0, sorted(os.sched_getaffinity(0))[:1])
    models = Path(__file__).resolve().parent.parent / "tognet" / "models"
    arms = ("floating", "sawyer", "panda")
    methods = ("TOG-Net", "Antipodal+Random")
    times: dict[tuple[str, str], list[float]] = defaultdict(list)
    stats: dict[tuple[str, str], dict[str, list[float]]] = defaultdict(lambda: defaultdict(list))
    exact: dict[str, list[int]] = defaultdict(list)
    where: dict[tuple[str, str], Counter[str]] = defaultdict(Counter)
    print(f"load average {os.getloadavg()[0]:.2f}")
    with tempfile.TemporaryDirectory() as tmp:
        generate_set("primitive", "test", args.objects, Path(tmp) / "objs")
        objects = load_catalog(Path(tmp) / "objs")
        for task in args.tasks:
            model = TOGNetPredictor.load(models / f"{task}.pt", num_threads=1)
            for obj in objects:
                sims = {}
                for arm in arms:
                    config = with_robot(SimConfig(), arm)  # an arm's preset, as tognet evaluate --robot
                    if args.base is not None and arm != "floating":
                        config = config.replace(robot=config.robot.replace(
                            base_position=tuple(args.base[:3]), base_yaw=args.base[3]))
                    sims[arm] = Simulator(config, task, obj)
                planners = {(arm, m): make_planner(m, sims[arm].task, task_model=model, sim=sims[arm])
                            for arm in arms for m in methods}
                for arm in arms:  # warm up (first calls allocate), untimed
                    warm = sims[arm].reset(99)
                    for m in methods:
                        try:
                            planners[(arm, m)](warm, np.random.default_rng(99))
                        except OutOfReach:
                            pass
                for s in range(args.scenes):
                    seed = 100 + s
                    obs = {arm: sims[arm].reset(seed) for arm in arms}
                    floating = {}
                    for arm in arms:
                        for m in methods:
                            rng = np.random.default_rng(seed)
                            t0 = time.perf_counter()
                            try:
                                plan = planners[(arm, m)](obs[arm], rng)
                            except OutOfReach as exc:
                                times[(arm, m)].append(time.perf_counter() - t0)
                                stats[(arm, m)]["out_of_reach"].append(1)
                                steps = [p.what for p in exc.passed] or list(exc.dropped.by_step
                                                                              if exc.dropped else {})
                                where[(arm, m)][f"{task}: {max(set(steps), key=steps.count)}"] += 1
                                continue
                            times[(arm, m)].append(time.perf_counter() - t0)
                            st = stats[(arm, m)]
                            st["out_of_reach"].append(0)
                            if arm == "floating":
                                floating[m] = plan
                                continue
                            info = plan.info["reach"]
                            st["dropped"].append(info["dropped"])
                            st["fallback"].append(int(info["rank"] > 0))
                            st["same"].append(int(np.array_equal(plan.grasp, floating[m].grasp)
                                                  and np.array_equal(plan.action, floating[m].action)))
                    if args.exact:
                        from tognet.grasping.antipodal import sample_antipodal
                        from tognet.grasping.depth import prepare_depth
                        from tognet.planning.config import PlanConfig

                        o = obs["floating"]
                        scene = prepare_depth(o.depth, o.camera)
                        rng = np.random.default_rng(seed)
                        cands = sample_antipodal(scene, None, PlanConfig().antipodal, rng)
                        for arm in arms[1:]:
                            reach = reach_of(sims[arm].config, sims[arm].task)
                            assert reach is not None
                            far, _ = reach.beyond(cands.grasps)
                            out = sum(reach.own_steps(g).stuck is not None for g in cands.grasps)
                            exact[arm].append(out)
                            exact[arm + "_envelope"].append(int(far.sum()))
                            exact[arm + "_total"].append(len(cands))
    n = len(times[("floating", methods[0])])
    print(f"{n} scenes ({', '.join(args.tasks)}; {args.objects} objects x {args.scenes} scenes), one core, "
          f"load average {os.getloadavg()[0]:.2f}")
    for m in methods:
        base = np.median(times[("floating", m)])
        for arm in arms:
            t = np.array(times[(arm, m)]) * 1000
            st = stats[(arm, m)]
            line = (f"{m:17s} {arm:8s} median {np.median(t):6.1f} ms (p90 {np.percentile(t, 90):6.1f}), "
                    f"x{np.median(t) / 1000 / base:.2f} the floating gripper's")
            if arm != "floating":
                d = np.array(st["dropped"] or [0])
                line += (f"; dropped before scoring: mean {d.mean():.1f} of 200 (max {d.max()}); "
                         f"fallbacks {sum(st['fallback'])}, out of reach {sum(st['out_of_reach'])}, "
                         f"the floating plan {sum(st['same'])} of {len(st['same'])}")
            print(line)
            if where[(arm, m)]:
                print("    out of reach at (the step most of its checked grasps failed at): "
                      + ", ".join(f"{k} {v}" for k, v in sorted(where[(arm, m)].items())))
    if args.exact:
        for arm in arms[1:]:
            print(f"{arm}: candidates whose own steps IK cannot reach: {sum(exact[arm])} of "
                  f"{sum(exact[arm + '_total'])}; the envelope drops {sum(exact[arm + '_envelope'])}")


if __name__ == "__main__":
    main()

"""Full simulated episodes per second on one core, per task, and where the time goes.

    .venv/bin/python benchmarks/bench_episodes.py [--episodes 40]

An episode = reset (drop and settle the object, disturb the camera, ray-cast the depth image, place the
props) + execute (approach, close, lift, hold, transport, the task's primitive, labels). Tools: the
hand-made T hammer and L tool with grasps that lift them (so every episode runs the primitive), plus
generated PG-Primitive objects with the default grasp. Models are built once per object (reported apart).
Episodes per CPU-second is the per-core throughput (the wall-clock rate is lower when other jobs share the
machine); the shares of physics and ray casting are of the wall time.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time

import numpy as np

from tognet.objects.generate import generate_set
from tognet.sim import SimConfig, Simulator
from tognet.sim.checks import HAMMER_GRASPS, SWEEP_GRASPS, hammer_action, sweep_action
from tognet.sim.tools import grasp_on_object, make_test_tools


def bench(task: str, records: list, episodes: int, cfg: SimConfig) -> dict:
    sims, build = [], 0.0
    for rec in records:
        t0 = time.perf_counter()
        sims.append(Simulator(cfg, task, rec))
        build += time.perf_counter() - t0
    total = 0.0
    cpu0 = time.process_time()
    full = 0
    for i in range(episodes):
        sim = sims[i % len(sims)]
        t0 = time.perf_counter()
        sim.reset(i)
        pos, rot = sim.object_pose()
        if sim.obj.object_id == "t_hammer":
            grasp = grasp_on_object(pos, rot, *HAMMER_GRASPS["far_end"][:2])
            action = hammer_action(sim, "far_end")
        elif sim.obj.object_id == "l_tool":
            grasp = grasp_on_object(pos, rot, *SWEEP_GRASPS["short_end"])
            action = sweep_action(sim, "short_end")
        else:
            grasp = sim.default_grasp()
            action = sim.task.random_action(np.random.default_rng(i))
        res = sim.execute(grasp, action, i)
        total += time.perf_counter() - t0
        full += int(res.grasp_success)
    cpu = time.process_time() - cpu0
    physics = sum(s.timers["physics"] for s in sims)
    ray = sum(s.timers["raycast"] for s in sims)
    steps = sum(s.steps for s in sims)
    return {
        "cpu_eps": episodes / cpu,
        "eps": episodes / total,
        "ms": 1000 * total / episodes,
        "physics": physics / total,
        "ray": ray / total,
        "steps": steps / episodes,
        "us_step": 1e6 * physics / max(steps, 1),
        "full": full / episodes,
        "build_ms": 1000 * build / len(records),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=40, help="episodes per task")
    args = parser.parse_args()
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    cfg = SimConfig()
    with tempfile.TemporaryDirectory() as tmp:
        tools = make_test_tools(tmp + "/tools")
        prims = generate_set("primitive", "train", 4, tmp + "/prim")
        for task, tool in (("hammering", "t_hammer"), ("sweeping", "l_tool")):
            records = [tools[tool], tools[tool], *prims]
            r = bench(task, records, args.episodes, cfg)
            rest = 1 - r["physics"] - r["ray"]
            print(
                f"{task:<10} {r['cpu_eps']:5.1f} episodes per CPU-second ({r['eps']:.1f}/s wall, "
                f"{r['ms']:.0f} ms each; {r['full']:.0%} lifted "
                f"and ran the primitive)  physics {r['physics']:.0%}  ray casting {r['ray']:.0%}  "
                f"rest {rest:.0%}"
                f"  | {r['steps']:.0f} steps/episode at {r['us_step']:.1f} us/step, "
                f"dt {cfg.physics.timestep * 1000:g} ms  | model build {r['build_ms']:.1f} ms/object",
                flush=True,
            )


if __name__ == "__main__":
    main()

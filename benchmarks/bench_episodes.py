"""Full simulated episodes per second on one core, per task, and where the time goes.

    .venv/bin/python benchmarks/bench_episodes.py [--episodes 60] [--repeats 3] [--config SIM.json]
        [--robot sawyer]

An episode = reset (drop and settle the object, disturb the camera, ray-cast the depth image, place the
props) + execute (approach, close, lift, hold, transport, the task's primitive, labels). Tools: the
hand-made T hammer and L tool with grasps that lift them (so every episode runs the primitive), plus
generated PG-Primitive objects with the default grasp. Models are built once per object (reported apart).

The same seeded episodes run ``--repeats`` times. Episodes are deterministic, so the fastest of the
repeats of each episode is its cost on an unshared core ("best-of" rate, as timeit takes the minimum);
the median of the repeats' rates shows what a shared core gave. Both are per CPU core (one process).
The shares (physics, ray casting, the rest) are of the last repeat's wall time, the clock the simulator's
own timers use (on a shared core, CPU and wall time differ).
This machine's speed drifts (a virtual machine: +-30 % within minutes, 2x between sessions), so every
repeat also times a fixed reference workload that does not depend on tognet (a MuJoCo box stack stepped
in C, a pure-Python loop): compare figures from different days through it.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import mujoco
import numpy as np

from tognet.config import ConfigError
from tognet.objects.generate import generate_set
from tognet.objects.handmade import grasp_on_object, make_test_tools
from tognet.robot.names import ROBOT_NAMES
from tognet.sim import SimConfig, Simulator
from tognet.sim.config import with_robot
from tognet.tasks import TASK_NAMES, get_props, get_task

_REFERENCE_XML = """
<mujoco>
  <option timestep="0.002" cone="elliptic" impratio="10"/>
  <worldbody>
    <geom type="plane" size="2 2 0.1"/>
    {boxes}
  </worldbody>
</mujoco>
"""


def reference_workload() -> dict:
    """Fixed machine-speed probes: us per step of a 6-box stack (MuJoCo, C) and ms of a Python loop."""
    boxes = "\n".join(
        f'<body pos="{0.01 * i:g} 0 {0.05 + 0.1 * i:g}"><freejoint/>'
        '<geom type="box" size="0.05 0.05 0.05"/></body>'
        for i in range(6)
    )
    model = mujoco.MjModel.from_xml_string(_REFERENCE_XML.format(boxes=boxes))
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, nstep=300)  # settle into a resting stack (contacts in every step)
    state = np.empty(mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_INTEGRATION))
    mujoco.mj_getState(model, data, state, mujoco.mjtState.mjSTATE_INTEGRATION)
    best_step = np.inf
    for _ in range(5):
        mujoco.mj_setState(model, data, state, mujoco.mjtState.mjSTATE_INTEGRATION)
        t0 = time.process_time()
        mujoco.mj_step(model, data, nstep=400)
        best_step = min(best_step, (time.process_time() - t0) / 400)
    best_py = np.inf
    for _ in range(5):
        t0 = time.process_time()
        s = 0
        for i in range(200_000):
            s += i * i
        best_py = min(best_py, time.process_time() - t0)
    return {"mj_us_step": 1e6 * best_step, "py_ms": 1e3 * best_py}


def _plan(sim: Simulator, i: int) -> tuple:
    """The task's scripted grasp and hand-computed action on its own hand-made tool (the one its scripted
    checks use, ``TaskProps.demo_grasp``); the default grasp and a random action on any other object."""
    pos, rot = sim.object_pose()
    props = sim.props
    if sim.obj.object_id == props.check_object and props.demo_grasp:
        point, jaw = props.check_grasps[props.demo_grasp][:2]
        return grasp_on_object(pos, rot, point, jaw), props.check_action(props.demo_grasp)
    assert sim.task is not None
    return sim.default_grasp(), sim.task.random_action(np.random.default_rng(i))


def episode_records(task: str, tools: dict, prims: list) -> list:
    """The benchmark's object mix for ``task``: its hand-made tool twice, then the PG-Primitive objects."""
    tool = tools[get_props(get_task(task)).check_object]
    return [tool, tool, *prims]


def bench(task: str, records: list, episodes: int, repeats: int, cfg: SimConfig) -> dict:
    sims, build = [], 0.0
    for rec in records:
        t0 = time.perf_counter()
        sims.append(Simulator(cfg, task, rec))
        build += time.perf_counter() - t0
    cpu = np.zeros((repeats, episodes))  # CPU seconds per episode and repeat
    wall = np.zeros((repeats, episodes))  # wall seconds, the clock of the simulator's own timers
    refs = []
    full = 0
    for r in range(repeats):
        refs.append(reference_workload())
        for s in sims:
            s.timers = {"physics": 0.0, "raycast": 0.0}
            s.steps = 0
        for i in range(episodes):
            sim = sims[i % len(sims)]
            t0, w0 = time.process_time(), time.perf_counter()
            sim.reset(i)
            grasp, action = _plan(sim, i)
            res = sim.execute(grasp, action, i)
            cpu[r, i] = time.process_time() - t0
            wall[r, i] = time.perf_counter() - w0
            full += int(r == 0 and res.grasp_success)
    total = wall[-1].sum()  # shares: the physics and ray-casting timers are wall time too
    physics = sum(s.timers["physics"] for s in sims)
    ray = sum(s.timers["raycast"] for s in sims)
    steps = sum(s.steps for s in sims)
    return {
        "best": episodes / cpu.min(axis=0).sum(),
        "median": float(np.median(episodes / cpu.sum(axis=1))),
        "runs": episodes / cpu.sum(axis=1),
        "physics": physics / total,
        "ray": ray / total,
        "steps": steps / episodes,
        "us_step": 1e6 * physics / max(steps, 1),
        "ms_ray": 1e3 * ray / episodes,
        "full": full / episodes,
        "build_ms": 1000 * build / len(records),
        "ref_mj": min(x["mj_us_step"] for x in refs),
        "ref_py": min(x["py_ms"] for x in refs),
    }


def _load_config(parser: argparse.ArgumentParser, path: Path | None) -> SimConfig:
    """The --config file's SimConfig (the defaults without one); a bad file ends with its message."""
    try:
        return SimConfig.load(path) if path else SimConfig()
    except ConfigError as exc:
        parser.error(str(exc))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=60, help="episodes per task and repeat")
    parser.add_argument("--repeats", type=int, default=3, help="runs of the same seeded episodes")
    parser.add_argument("--tasks", nargs="+", default=list(TASK_NAMES), choices=TASK_NAMES,
                        help="tasks to time (default: every registered task)")
    parser.add_argument("--config", type=Path, help="SimConfig JSON to time instead of the defaults")
    parser.add_argument("--robot", choices=ROBOT_NAMES,
                        help="what carries the hand (an arm: its preset on top)")
    args = parser.parse_args()
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    cfg = _load_config(parser, args.config)
    if args.robot:
        cfg = with_robot(cfg, args.robot)
    with tempfile.TemporaryDirectory() as tmp:
        tools = make_test_tools(tmp + "/tools")
        prims = generate_set("primitive", "train", 4, tmp + "/prim")
        for task in args.tasks:
            r = bench(task, episode_records(task, tools, prims), args.episodes, args.repeats, cfg)
            rest = 1 - r["physics"] - r["ray"]
            runs = " ".join(f"{x:.1f}" for x in r["runs"])
            print(
                f"{task:<10} {r['best']:5.1f} episodes/s/core best-of-{args.repeats} "
                f"(runs {runs}; median {r['median']:.1f}); {r['full']:.0%} lifted and ran the primitive | "
                f"physics {r['physics']:.0%} ({r['steps']:.0f} steps at {r['us_step']:.1f} us), ray casting "
                f"{r['ray']:.0%} ({r['ms_ray']:.1f} ms), rest {rest:.0%} (last run) | model build "
                f"{r['build_ms']:.1f} ms/object | reference: box stack {r['ref_mj']:.1f} us/step, "
                f"Python loop {r['ref_py']:.1f} ms",
                flush=True,
            )


if __name__ == "__main__":
    main()

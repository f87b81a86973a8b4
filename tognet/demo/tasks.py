"""The task part of ``tognet demo``: does the grasp matter, and what does an episode look like?

Runs every registered task's scripted checks with a few seeds (e.g. the hand-made T hammer grasped at
the far end of its handle vs by its head), draws the antipodal candidates on one simulated depth image,
and animates one hammering episode, and with the robot extra installed the same episode on the Sawyer
arm.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import typer


def checks() -> list[tuple[str, str, str]]:
    """(task, grasp name, what the grasp is) for every registered task's scripted-check grasps."""
    from tognet.tasks import TASK_NAMES, get_props, get_task

    rows = []
    for task in TASK_NAMES:
        props = get_props(get_task(task))
        rows += [(task, name, props.check_texts.get(name, name)) for name in props.check_grasps]
    return rows


def run_task_demo(out: Path, seeds: int = 5, gif: bool = True) -> list[Path]:
    """Run the checks and write the pictures into ``out``; returns the files written."""
    from tognet.grasping import AntipodalConfig, prepare_depth
    from tognet.grasping.draw import render_grasps
    from tognet.objects.handmade import make_test_tools
    from tognet.sim import SimConfig, Simulator
    from tognet.sim.scripted_checks import run_check

    written: list[Path] = []
    typer.echo(f"does the grasp matter? scripted checks, {seeds} scenes each (hand-computed actions):")
    for task, grasp, text in checks():
        result = run_check(task, grasp, range(seeds))
        typer.echo(f"  {task:9s} {text:50s} task success {result.task_successes}/{result.trials}")

    tools = make_test_tools(out / "tools")
    sim = Simulator(SimConfig(), "hammering", tools["t_hammer"])
    obs = sim.reset(seed=0)
    scene = prepare_depth(obs.depth, obs.camera)
    _, _, png = render_grasps(scene, out / "hammer_candidates.png", config=AntipodalConfig(), use_nms=True)
    written.append(png)
    typer.echo(f"antipodal candidates (NMS modes) on the simulated depth image -> {png}")
    if gif:
        written.append(_hammering_gif(sim, out / "hammering.gif", "one hammering episode (far-end grasp)"))
        if _robot_extra():
            from tognet.sim.config import with_robot

            arm = Simulator(with_robot(SimConfig(), "sawyer"), "hammering", tools["t_hammer"])
            arm.reset(seed=0)
            written.append(_hammering_gif(arm, out / "hammering_sawyer.gif",
                                          "the same episode on the Sawyer arm"))
    return written


def _robot_extra() -> bool:
    """Whether the optional robot extra (robosuite's arm models, mink) is installed."""
    import importlib.util

    return all(importlib.util.find_spec(name) is not None for name in ("robosuite", "mink"))


def _hammering_gif(sim: Any, path: Path, what: str) -> Path:
    """Animate the far-end grasp's hammering episode (seed 0) of a reset simulator into ``path``."""
    from tognet.objects.handmade import grasp_on_object
    from tognet.sim.render import GifRecorder
    from tognet.tasks.hammering_props import HAMMER_GRASPS, hammer_action

    pos, rot = sim.object_pose()
    point, jaw = HAMMER_GRASPS["far_end"][0], HAMMER_GRASPS["far_end"][1]
    grasp = grasp_on_object(pos, rot, point, jaw)
    action = hammer_action(sim, "far_end")
    recorder = GifRecorder(sim.model, every=1)
    try:
        with sim.recording(recorder):
            result = sim.execute(grasp, np.asarray(action), seed=0)
        recorder.save(path)
    finally:
        recorder.close()
    typer.echo(f"{what}: grasp_success={result.grasp_success} task_success={result.task_success} -> {path}")
    return path

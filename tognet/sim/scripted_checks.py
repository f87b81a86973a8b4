"""Scripted checks that the tasks make the grasp matter (hand-made tools, hand-computed actions).

Each task names its hand-made object, its check grasps on it and how to compute an action for each by
hand (:attr:`tognet.tasks.props.TaskProps.check_grasps`, :meth:`~tognet.tasks.props.TaskProps.check_action`);
the expectations (e.g. one grasp succeeds in >= 90 % of seeds, another fails in most) are in the tests and
``benchmarks/scripted_checks.py``.
"""

from __future__ import annotations

import tempfile
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from tognet.objects.handmade import grasp_on_object, make_l_tool, make_t_hammer
from tognet.sim.config import SimConfig
from tognet.sim.simulator import Simulator
from tognet.tasks import get_props, get_task

#: The hand-made objects the checks may use, by id (``TaskProps.check_object``).
CHECK_OBJECTS = {"t_hammer": make_t_hammer, "l_tool": make_l_tool}


@dataclass
class CheckResult:
    """Outcome of one scripted check over many seeds."""

    name: str
    trials: int
    task_successes: int
    grasp_successes: int
    invalid: int
    failures: dict[str, int] = field(default_factory=dict)
    details: list[dict[str, Any]] = field(default_factory=list)

    @property
    def rate(self) -> float:
        """Task success rate over the valid trials."""
        valid = self.trials - self.invalid
        return self.task_successes / valid if valid else 0.0

    def line(self) -> str:
        """One printable line."""
        fails = ", ".join(f"{k}={v}" for k, v in sorted(self.failures.items()))
        return (
            f"{self.name:<44} task {self.task_successes:>3}/{self.trials - self.invalid:<3} "
            f"= {self.rate:6.1%}"
            f"  grasp {self.grasp_successes}/{self.trials}  invalid {self.invalid}  [{fails}]"
        )


def run_check(
    task: str,
    grasp_name: str | tuple,
    seeds: range,
    config: SimConfig | None = None,
    clip: bool = True,
    folder: str | Path | None = None,
    yaw: float = 0.0,
    label: str = "",
) -> CheckResult:
    """Run one scripted check over ``seeds``; each seed is a new scene and one trial.

    ``grasp_name`` names a grasp of the task's ``check_grasps`` or is a grasp spec of the same form (a
    task's props module may offer more, e.g. grasps along a handle); ``yaw`` is the start yaw (a_phi) to
    try, for a task whose hand-computed action takes one.
    """
    config = config or SimConfig()
    props = get_props(get_task(task, config.task_config(task)))
    config = config.replace(**{task: props.check_config(config.task_config(task))})
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(folder) if folder else Path(tmp)
        obj = CHECK_OBJECTS[props.check_object](root)
        sim = Simulator(config, task, obj)
        spec = sim.props.check_grasps[grasp_name] if isinstance(grasp_name, str) else grasp_name
        point, jaw = spec[0], spec[1]
        name = label or f"{task}/{grasp_name}{'' if clip else ' (yaw unclipped)'}"
        result = CheckResult(name, 0, 0, 0, 0)
        counts: Counter[str] = Counter()
        for seed in seeds:
            sim.reset(seed)
            pos, rot = sim.object_pose()
            grasp = grasp_on_object(pos, rot, point, jaw)
            action = sim.props.check_action(grasp_name, clip=clip, yaw=yaw)
            res = sim.execute(grasp, action, seed)
            result.trials += 1
            result.task_successes += int(res.task_success)
            result.grasp_successes += int(res.grasp_success)
            result.invalid += int(not res.valid)
            counts[res.failure.value] += 1
            result.details.append(
                {
                    "seed": seed,
                    "action": action.tolist(),
                    "failure": res.failure.value,
                    **{k: v for k, v in res.info.items() if k in sim.props.outcome_keys},
                }
            )
        result.failures = dict(counts)
    return result


def check_action(sim: Simulator, grasp_name: str | tuple, clip: bool = True, yaw: float = 0.0) -> np.ndarray:
    """The hand-computed action of the simulator's task for a check grasp in its settled scene."""
    return sim.props.check_action(grasp_name, clip=clip, yaw=yaw)

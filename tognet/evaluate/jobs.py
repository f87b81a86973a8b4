"""The unit of evaluation work: one test object, a few scenes, every method on every scene.

:func:`run_eval_job` runs in a worker (:mod:`tognet.jobs.workers`, local process or Ray):
it builds the simulator once, resets each scene from its seed, gives every method the same observation
and a generator in the same state (so the model planners start from the same antipodal candidates), and
executes each plan from the same settled scene with the same execution-noise seed. Comparisons between
methods are therefore paired scene by scene. Everything derives from the job's seeds, so a rerun gives
the same records.

Outcomes beyond the simulator's: ``unreachable`` (the plan's grasp or start pose lies outside the
gripper's travel: the method's failure, valid) and ``no_grasp`` (no antipodal candidate: a failure of
every method that needs one).
"""

from __future__ import annotations

import time
import traceback
import zlib
from collections import Counter
from dataclasses import dataclass
from typing import Any

import numpy as np

from tognet.evaluate.config import EvalConfig
from tognet.io import short_digest
from tognet.jobs.models import load_model
from tognet.jobs.output import JobOutput
from tognet.jobs.scenes import reset_scene
from tognet.objects.record import ObjectRecord

UNREACHABLE = "unreachable"
NO_GRASP = "no_grasp"


@dataclass(frozen=True)
class EvalJob:
    """One object's scenes for every method (``index`` and ``obj`` as the executors expect of a job)."""

    task: str
    category: str
    index: int
    obj: ObjectRecord
    scenes: int
    methods: tuple[str, ...]
    config: EvalConfig
    grasp_model: str | None = None
    task_model: str | None = None
    search_model: str | None = None

    @property
    def planned(self) -> int:
        """Episodes the job runs (scenes x methods)."""
        return self.scenes * len(self.methods)

    def seed(self, *more: int) -> list[int]:
        """The job's seed sequence entropy, extended by ``more``."""
        return [self.config.seed, zlib.crc32(self.task.encode()), zlib.crc32(self.category.encode()),
                self.index, *more]

    def scene_seed(self, scene: int) -> int:
        """The simulator seed of the job's ``scene``-th scene (a 32-bit unsigned integer)."""
        return int(np.random.SeedSequence(self.seed(scene, 1)).generate_state(1)[0])


def plan_eval_jobs(task: str, category: str, objects: list[ObjectRecord], episodes: int,
                   methods: tuple[str, ...], config: EvalConfig, grasp_model: str | None = None,
                   task_model: str | None = None, search_model: str | None = None) -> list[EvalJob]:
    """Jobs for ``episodes`` scenes (per method) of one category: objects in a seeded order, each job a
    new object until every object has one, then around again."""
    if not objects:
        raise ValueError(f"{category}: no test objects")
    spj = config.scenes_per_job
    n_jobs = max(1, -(-episodes // spj))
    rng = np.random.default_rng([config.seed, zlib.crc32(task.encode()), zlib.crc32(category.encode()), 7])
    order = np.concatenate([rng.permutation(len(objects)) for _ in range(-(-n_jobs // len(objects)))])
    return [EvalJob(task, category, j, objects[int(order[j])], min(spj, episodes - j * spj), methods, config,
                    grasp_model, task_model, search_model) for j in range(n_jobs)]


def _pose(sim: Any) -> list[float]:
    pos, rot = sim.object_pose()
    return [float(v) for v in np.concatenate([pos, rot.reshape(-1)])]


def state_digest(sim: Any) -> str:
    """A short hash of the simulator's integration state (positions, velocities, actuators, time): the
    state every trial starts from. (``object_pose`` reads positions MuJoCo derives in a step; right after
    ``reset`` they are those of the last settling step's start, ~1e-7 m off those of the restored state.)"""
    return short_digest(np.ascontiguousarray(sim.save_state()).tobytes())


def run_eval_job(job: EvalJob) -> JobOutput:
    """Run one evaluation job (in a worker). Never raises for a bad object: a job whose object cannot be
    simulated returns no records and the error. Records are in ``columns["records"]`` (a list of dicts)."""
    try:
        return _run_eval_job(job)
    except Exception as exc:  # one bad object must never end an evaluation
        detail = traceback.format_exception_only(type(exc), exc)[-1].strip()
        return JobOutput(job.index, {"records": []}, {"object": job.obj.object_id},  # type: ignore[dict-item]
                         error=f"{job.obj.object_id}: {detail}")


def _run_eval_job(job: EvalJob) -> JobOutput:
    from tognet.planning import PlanningError, make_planner
    from tognet.planning.reach import OutOfReach
    from tognet.sim import Simulator

    t_start = time.perf_counter()
    sim = Simulator(job.config.sim, job.task, job.obj)
    grasp_model = load_model(job.grasp_model) if job.grasp_model else None
    task_model = load_model(job.task_model) if job.task_model else None
    search_model = load_model(job.search_model) if job.search_model else None
    planners = {m: make_planner(m, sim.task, grasp_model=grasp_model, task_model=task_model,
                                config=job.config.plan, sim=sim, search_model=search_model)
                for m in job.methods}
    records: list[dict[str, Any]] = []
    stats: Counter[str] = Counter()
    for s in range(job.scenes):
        scene_seed = job.scene_seed(s)
        obs = reset_scene(sim, scene_seed, stats)
        if obs is None:
            continue
        depth_sha = short_digest(np.ascontiguousarray(obs.depth).tobytes())
        facts = sim.task.scene_facts(obs.info.get("layout", {})) if sim.task is not None else {}
        for method, planner in planners.items():
            base = {"task": job.task, "category": job.category, "object_id": job.obj.object_id,
                    "job": job.index, "scene": s, "scene_seed": scene_seed, "method": method,
                    **facts, "depth_sha": depth_sha}
            rng = np.random.default_rng(job.seed(s, 2))  # the same state for every method
            try:
                plan = planner(obs, rng)
            except PlanningError as exc:  # no candidate; with an arm, none within its reach
                failure = UNREACHABLE if isinstance(exc, OutOfReach) else NO_GRASP
                records.append({**base, "grasp": None, "action": None, "valid": True, "grasp_success": False,
                                "task_success": False, "failure": failure, "timing": {}, "scores": {}})
                continue
            rec = {**base, "grasp": [float(v) for v in plan.grasp], "action": [float(v) for v in plan.action],
                   "timing": plan.timing, "scores": plan.scores,
                   "search_trials": plan.info.get("search_trials"), "pose": _pose(sim),
                   "state_sha": state_digest(sim)}
            if "source" in plan.info:  # Oracle+: which of its stages found the plan
                rec["source"] = plan.info["source"]
            if "reach" in plan.info:  # with an arm: how far down the method's ranking its plan is
                rec["reach"] = {k: plan.info["reach"].get(k) for k in ("rank", "dropped", "checked")}
            t0 = time.perf_counter()
            try:
                result = sim.execute(plan.grasp_pose, plan.action, seed=job.config.trial_seed)
            except ValueError:  # out of the gripper's reach: this method's failure
                rec.update(valid=True, grasp_success=False, task_success=False, failure=UNREACHABLE)
            else:
                rec.update(valid=bool(result.valid), grasp_success=bool(result.grasp_success),
                           task_success=bool(result.task_success), failure=result.failure.value)
            rec["execute_seconds"] = time.perf_counter() - t0
            records.append(rec)
    stats["seconds"] = time.perf_counter() - t_start  # type: ignore[assignment]
    return JobOutput(job.index, {"records": records}, dict(stats))  # type: ignore[dict-item]

"""The unit of collection work: a job is one object, a few scenes, several trials per scene.

:func:`run_job` runs in a worker (a local process or a Ray task) and returns the job's episode records as
columns; the coordinator writes them as one shard named after the job. Everything in a job derives from
its seed, so a job rerun (after a worker died or the run was killed) gives the same records, and so does
running it on another kind of worker.

The glue from a simulator trial to a dataset record lives here once (:func:`trial_records`): crops and z
of the executed grasp, the grasp and action as executed (rounded to float32 first, so that a stored
record replays exactly: ``Simulator(cfg.sim, task, obj).reset(scene_seed)`` then
``execute(grasp, action, seed=trial)``), labels, failure reason, object id, scene seed, trial index,
policy sources and the score the policy chose by; the collection config's hash is in the shard's meta.

A round's policies come from :mod:`tognet.policies`, built from the round's policy name in one place
(:func:`round_policies`); the executors that run jobs are :mod:`tognet.jobs`'.
"""

from __future__ import annotations

import time
import traceback
import zlib
from collections import Counter
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tognet.collect.config import MODEL_POLICIES, ROUND_POLICIES, CollectConfig, RoundPolicy
from tognet.jobs.models import load_model
from tognet.jobs.output import JobOutput
from tognet.jobs.scenes import reset_scene
from tognet.objects.record import ObjectRecord
from tognet.policies.action import ExpertActions, NoActions, PolicyActions, UniformActions
from tognet.policies.action_search import ActionSearchActions, ActionSearchGrasps, SearchCandidateGrasps
from tognet.policies.config import PolicyConfig
from tognet.policies.grasp import CEMGrasp, NMSGrasps
from tognet.policies.mix import EpsilonGreedyActions, EpsilonGreedyGrasps, ExpertMixActions
from tognet.policies.view import ActionPolicy, GraspPolicy, SceneView, check_predictor_crops
from tognet.tasks import GRASP_ONLY

#: The grasp-only task (no primitive): trains the task-agnostic Q_G model.


@dataclass(frozen=True)
class Job:
    """One job: which object, which seeds, which policy and models."""

    task: str
    round: int
    index: int
    obj: ObjectRecord
    policy: RoundPolicy
    config: CollectConfig
    grasp_model: str | None = None
    task_model: str | None = None

    @property
    def planned(self) -> int:
        """Trials the job runs when every scene has candidates."""
        return self.config.scenes_per_job * self.config.trials_per_scene

    def seed(self, *more: int) -> list[int]:
        """The job's seed sequence entropy, extended by ``more``."""
        return [self.config.seed, zlib.crc32(self.task.encode()), self.round, self.index, *more]

    def scene_seed(self, scene: int) -> int:
        """The simulator seed of the job's ``scene``-th scene (a 32-bit unsigned integer)."""
        return int(np.random.SeedSequence(self.seed(scene, 1)).generate_state(1)[0])


def plan_jobs(task: str, round_index: int, objects: list[ObjectRecord], episodes: int, policy: RoundPolicy,
              config: CollectConfig, grasp_model: str | None = None, task_model: str | None = None
              ) -> list[Job]:
    """The jobs of one round: enough for ``episodes`` trials, objects visited in a seeded order (each
    round its own), cycling through all of them."""
    if not objects:
        raise ValueError("no objects to collect on")
    per_job = config.scenes_per_job * config.trials_per_scene
    n_jobs = max(1, -(-episodes // per_job))
    rng = np.random.default_rng([config.seed, zlib.crc32(task.encode()), round_index, 7])
    order = np.concatenate([rng.permutation(len(objects)) for _ in range(-(-n_jobs // len(objects)))])
    return [Job(task, round_index, j, objects[int(order[j])], policy, config, grasp_model, task_model)
            for j in range(n_jobs)]


def trial_records(view: SceneView, grasps: NDArray[np.float64], actions: NDArray[np.float64],
                  results: list[Any], grasp_source: NDArray[np.int8], action_source: NDArray[np.int8],
                  score: NDArray[np.float32], object_id: str, scene_seed: int,
                  trials: NDArray[np.int64]) -> dict[str, NDArray[Any]]:
    """Episode columns for executed trials of one scene (``results``: the simulator's TrialResults)."""
    crops, z = view.crops(grasps)
    n = len(results)
    return {
        "crop": crops.astype(np.float16),
        "z": z,
        "grasp": grasps.astype(np.float32),
        "action": actions.astype(np.float32),
        "grasp_success": np.array([r.grasp_success for r in results], dtype=np.uint8),
        "task_success": np.array([r.task_success for r in results], dtype=np.uint8),
        "valid": np.array([r.valid for r in results], dtype=np.uint8),
        "failure": np.array([r.failure.value for r in results]),
        "object_id": np.full(n, object_id),
        "scene_seed": np.full(n, scene_seed, dtype=np.int64),
        "trial": trials.astype(np.int32),
        "grasp_source": grasp_source,
        "action_source": action_source,
        "score": score.astype(np.float32),
        "progress": np.array([_progress(view.task, r) for r in results], dtype=np.float32),
        "lift_tilt": np.array([r.info.get("lift_tilt", -1.0) for r in results], dtype=np.float32),
    }


def _progress(task: Any, result: Any) -> float:
    """The task's graded outcome (in [0, 1]) of a trial that held the tool and ran the primitive; -1 where
    it is unknown (no task, the grasp failed, an invalid trial, a task that does not grade)."""
    if task is None or not (result.valid and result.grasp_success):
        return -1.0
    value = float(task.progress(result.info))
    return value if np.isfinite(value) else -1.0


def run_job(job: Job) -> JobOutput:
    """Run one job (in a worker): every scene and trial, labels from the simulator. Never raises for a bad
    object or scene: a job whose object cannot be simulated returns no records and the error."""
    try:
        return _run_job(job)
    except Exception as exc:  # one bad object must never end a round
        detail = traceback.format_exception_only(type(exc), exc)[-1].strip()
        return JobOutput(job.index, {}, {"object": job.obj.object_id}, error=f"{job.obj.object_id}: {detail}")


def round_policies(job: Job, sim: Any, grasp_model: Any = None, task_model: Any = None
                   ) -> tuple[GraspPolicy, ActionPolicy]:
    """The round's grasp and action policies, by its policy name (:data:`RoundPolicy`).

    ``nms_uniform`` explores: NMS grasps (ranked by ``grasp_model``'s Q_G, else antipodal quality) and
    uniform actions. ``epsilon_greedy`` is the task model's CEM grasp and noisy action mean, mixed with
    that exploration per trial (epsilon_1, epsilon_2); with a model whose task stream sees the action, the
    greedy grasp and action are the learned action search's (:mod:`tognet.policies.action_search`).
    ``search_candidates`` is that mix with the search's best few candidates of each scene in turn as the
    greedy grasps.
    Exploring actions are the simulator's expert ones with probability ``expert_actions`` (tasks only;
    the grasp-only task has no action)."""
    p = job.config.policy
    explore_grasps = NMSGrasps(p, grasp_model)
    explore_actions: ActionPolicy = NoActions() if job.task == GRASP_ONLY else UniformActions()
    if job.task != GRASP_ONLY and p.expert_actions > 0:
        explore_actions = ExpertMixActions(explore_actions, ExpertActions(sim), p.expert_actions)
    if job.policy == "nms_uniform":
        return explore_grasps, explore_actions
    greedy_grasps, greedy_actions = _greedy_policies(job.policy, p, task_model)
    return (EpsilonGreedyGrasps(greedy_grasps, explore_grasps, p.epsilon_grasp),
            EpsilonGreedyActions(greedy_actions, explore_actions, p.epsilon_action))


def _greedy_policies(policy: str, p: PolicyConfig, task_model: Any) -> tuple[GraspPolicy, ActionPolicy]:
    """The greedy half of a round that needs a model: CEM and the policy's action mean, the learned action
    search's grasp and action (a model whose task stream sees the action), or that search's best
    candidates in turn (``search_candidates``)."""
    if policy not in MODEL_POLICIES:
        raise ValueError(f"unknown round policy {policy!r}; use {', '.join(ROUND_POLICIES)}")
    if task_model is None:
        raise ValueError(f"a {policy} round needs the last round's task model")
    searching = getattr(task_model, "action_conditioned", False)
    if policy == "search_candidates" and not searching:
        raise ValueError("a search_candidates round needs an action-search model (task_head 'action')")
    if not searching:
        return CEMGrasp(p, task_model), PolicyActions(task_model, p.action_noise)
    grasps: GraspPolicy = ActionSearchGrasps(task_model, p.action_search)
    if policy == "search_candidates":
        grasps = SearchCandidateGrasps(task_model, p.action_search, p.search_candidates)
    return grasps, ActionSearchActions(task_model, p.action_search, p.action_noise)


def _run_job(job: Job) -> JobOutput:
    from tognet.geometry import Grasp
    from tognet.grasping.antipodal import sample_antipodal
    from tognet.grasping.depth import prepare_depth
    from tognet.sim import Simulator

    cfg = job.config
    t0 = time.perf_counter()
    grasp_model = load_model(job.grasp_model) if job.grasp_model else None
    task_model = load_model(job.task_model) if job.task_model else None
    for model, what in ((grasp_model, job.grasp_model), (task_model, job.task_model)):
        if model is not None:
            check_predictor_crops(model, cfg.crop, str(what))
    sim = Simulator(cfg.sim, job.task, job.obj)
    grasp_policy, action_policy = round_policies(job, sim, grasp_model, task_model)
    parts: list[dict[str, NDArray[Any]]] = []
    stats: Counter[str] = Counter()
    trials = cfg.trials_per_scene
    for s in range(cfg.scenes_per_job):
        scene_seed = job.scene_seed(s)
        obs = reset_scene(sim, scene_seed, stats)
        if obs is None:
            continue
        rng = np.random.default_rng(job.seed(s, 2))
        scene = prepare_depth(obs.depth, obs.camera)
        cands = sample_antipodal(scene, None, cfg.antipodal, rng)
        if len(cands) == 0:
            stats["scenes_without_candidates"] += 1
            continue
        view = SceneView(scene, cands, sim.task, cfg.crop)
        pick = grasp_policy(view, trials, rng)
        grasps = pick.grasps.astype(np.float32).astype(np.float64)  # as stored, so records replay exactly
        acts = action_policy(view, grasps, rng)
        actions = acts.actions.astype(np.float32).astype(np.float64)
        results, kept = [], []
        for t in range(trials):
            try:
                results.append(sim.execute(Grasp.from_array(grasps[t]), None if job.task == GRASP_ONLY
                                           else actions[t], seed=t))
                kept.append(t)
            except ValueError:  # a grasp or start pose out of the gripper's reach: not a trial
                stats["unreachable"] += 1
        if not kept:
            continue
        k = np.asarray(kept)
        parts.append(trial_records(view, grasps[k], actions[k], results, pick.source[k], acts.source[k],
                                   pick.score[k], job.obj.object_id, scene_seed, k))
    stats["seconds"] = time.perf_counter() - t0  # type: ignore[assignment]
    columns = {name: np.concatenate([p[name] for p in parts]) for name in parts[0]} if parts else {}
    return JobOutput(job.index, columns, dict(stats))

"""Self-supervision: trials to records, each round's policies, rounds, the whole pipeline.

    from tognet.collect import CollectConfig, RoundConfig, collect_round, run_pipeline, load_preset

A round's grasp and action policies are built from :mod:`tognet.policies` (:func:`tognet.collect.jobs.
round_policies`); its jobs run in local worker processes by default and on Ray with one flag
(:mod:`tognet.jobs.workers`).
"""

from typing import TYPE_CHECKING

from tognet.lazy_names import lazy_names

if TYPE_CHECKING:
    from tognet.collect.config import CollectConfig, PipelineConfig, RoundConfig, load_preset
    from tognet.collect.jobs import Job, plan_jobs, round_policies, run_job
    from tognet.collect.pipeline import run_pipeline
    from tognet.collect.rounds import collect_round, summarise_round

_WHERE = {
    "CollectConfig": "tognet.collect.config",
    "PipelineConfig": "tognet.collect.config",
    "RoundConfig": "tognet.collect.config",
    "load_preset": "tognet.collect.config",
    "Job": "tognet.collect.jobs",
    "plan_jobs": "tognet.collect.jobs",
    "round_policies": "tognet.collect.jobs",
    "run_job": "tognet.collect.jobs",
    "run_pipeline": "tognet.collect.pipeline",
    "collect_round": "tognet.collect.rounds",
    "summarise_round": "tognet.collect.rounds",
}

__getattr__, __dir__ = lazy_names(__name__, _WHERE)

__all__ = [
    "CollectConfig",
    "Job",
    "PipelineConfig",
    "RoundConfig",
    "collect_round",
    "load_preset",
    "plan_jobs",
    "round_policies",
    "run_job",
    "run_pipeline",
    "summarise_round",
]

"""Self-supervision: trials to records, grasp and action policies, rounds, workers, the whole pipeline.

    from tognet.collect import CollectConfig, RoundConfig, collect_round, run_pipeline, load_preset

Jobs run in local worker processes by default and on Ray with one flag (:mod:`tognet.collect.workers`).
"""

from typing import TYPE_CHECKING

from tognet.lazy_names import lazy_names

if TYPE_CHECKING:
    from tognet.collect.config import CollectConfig, PipelineConfig, PolicyConfig, RoundConfig, load_preset
    from tognet.collect.jobs import Job, JobOutput, plan_jobs, run_job
    from tognet.collect.pipeline import run_pipeline
    from tognet.collect.rounds import collect_round, summarise_round
    from tognet.collect.workers import LocalExecutor, RayExecutor, make_executor

_WHERE = {
    "CollectConfig": "tognet.collect.config",
    "PipelineConfig": "tognet.collect.config",
    "PolicyConfig": "tognet.collect.config",
    "RoundConfig": "tognet.collect.config",
    "load_preset": "tognet.collect.config",
    "Job": "tognet.collect.jobs",
    "JobOutput": "tognet.collect.jobs",
    "plan_jobs": "tognet.collect.jobs",
    "run_job": "tognet.collect.jobs",
    "run_pipeline": "tognet.collect.pipeline",
    "collect_round": "tognet.collect.rounds",
    "summarise_round": "tognet.collect.rounds",
    "LocalExecutor": "tognet.collect.workers",
    "RayExecutor": "tognet.collect.workers",
    "make_executor": "tognet.collect.workers",
}

__getattr__, __dir__ = lazy_names(__name__, _WHERE)

__all__ = [
    "CollectConfig",
    "Job",
    "JobOutput",
    "LocalExecutor",
    "PipelineConfig",
    "PolicyConfig",
    "RayExecutor",
    "RoundConfig",
    "collect_round",
    "load_preset",
    "make_executor",
    "plan_jobs",
    "run_job",
    "run_pipeline",
    "summarise_round",
]

"""Running jobs for collection and evaluation alike: executors, a job's output, models, scenes.

A *job* is any picklable object with an ``index`` and an ``obj`` (the object it runs on); a *job function*
is a module-level function of a job returning a :class:`JobOutput`. The executors run job functions in
local worker processes or on Ray and hand each output to the caller as it arrives.

    workers.py  LocalExecutor, RayExecutor, make_executor, default_workers
    output.py   JobOutput (records as columns, counters, an error)
    models.py   load_model (one predictor per checkpoint and worker process)
    scenes.py   reset_scene (a scene the simulator cannot set up is counted, not raised)
    files.py    a job's files shipped to Ray nodes by content, cached per node by sha256
    localcluster.py  a Ray cluster on this machine whose worker nodes cannot see chosen folders
"""

from typing import TYPE_CHECKING

from tognet.lazy_names import lazy_names

if TYPE_CHECKING:
    from tognet.jobs.models import load_model
    from tognet.jobs.output import JobOutput
    from tognet.jobs.scenes import reset_scene
    from tognet.jobs.workers import Executor, LocalExecutor, RayExecutor, default_workers, make_executor

_WHERE = {
    "load_model": "tognet.jobs.models",
    "JobOutput": "tognet.jobs.output",
    "reset_scene": "tognet.jobs.scenes",
    "Executor": "tognet.jobs.workers",
    "LocalExecutor": "tognet.jobs.workers",
    "RayExecutor": "tognet.jobs.workers",
    "default_workers": "tognet.jobs.workers",
    "make_executor": "tognet.jobs.workers",
}

__getattr__, __dir__ = lazy_names(__name__, _WHERE)

__all__ = [
    "Executor",
    "JobOutput",
    "LocalExecutor",
    "RayExecutor",
    "default_workers",
    "load_model",
    "make_executor",
    "reset_scene",
]

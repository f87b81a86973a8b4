"""Where jobs run: local worker processes by default, a Ray cluster when one machine is not enough.

Both executors run a module-level job function ``fn`` (collection's ``run_job``, the evaluation's
``run_eval_job``, ...) on each job and hand each :class:`JobOutput` to the coordinator's callback as
it arrives (in completion order; shards are named by job, so the order does not matter). A worker that
dies (killed, out of memory, a crash inside MuJoCo) is reported and its jobs run again, up to
``max_retries`` times; after that the job is reported as failed and the round goes on.
"""

from __future__ import annotations

import multiprocessing
import os
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from typing import Any, Protocol

from tognet.jobs.output import JobOutput

OnResult = Callable[[Any, JobOutput], None]
#: A job function: a picklable module-level function of a job (anything with ``index`` and ``obj``).
JobFn = Callable[[Any], JobOutput]


class Executor(Protocol):
    """Runs ``fn`` on each job and calls ``on_result`` with the job and its output, in the caller's thread."""

    workers: int

    def run(self, jobs: list[Any], on_result: OnResult, log: Callable[[str], None], fn: JobFn
            ) -> None: ...

    def close(self) -> None: ...


def default_workers() -> int:
    """The number of cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not Linux
        return max(1, os.cpu_count() or 1)


def _exit_with_parent(parent: int, every: float = 1.0) -> None:
    """Worker initialiser: a thread that ends this worker once its coordinator is gone (killed, even with
    SIGKILL), so no orphan keeps a core busy; a spawned worker otherwise waits on its queue for ever."""
    import threading
    import time

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(every)
        os._exit(1)

    threading.Thread(target=watch, name="tognet-parent-watch", daemon=True).start()


class LocalExecutor:
    """``workers`` local processes (spawned: a fresh interpreter, no torch threads inherited from a parent
    that trains). ``workers=0`` runs the jobs in this process (debugging; a crash ends the run)."""

    def __init__(self, workers: int | None = None, max_retries: int = 3) -> None:
        self.workers = default_workers() if workers is None else int(workers)
        if self.workers < 0:
            raise ValueError(f"workers must be >= 0, got {workers}")
        self.max_retries = max_retries
        self._pool: ProcessPoolExecutor | None = None

    def _new_pool(self) -> ProcessPoolExecutor:
        return ProcessPoolExecutor(max_workers=self.workers, mp_context=multiprocessing.get_context("spawn"),
                                   initializer=_exit_with_parent, initargs=(os.getpid(),))

    def run(self, jobs: list[Any], on_result: OnResult, log: Callable[[str], None], fn: JobFn
            ) -> None:
        if self.workers == 0:
            for job in jobs:
                on_result(job, fn(job))
            return
        pending = list(reversed(jobs))  # popped from the end: in job order
        retries: dict[int, int] = {}
        running: dict[Future[JobOutput], Any] = {}
        if self._pool is None:
            self._pool = self._new_pool()
        while pending or running:
            while pending and len(running) < 2 * self.workers:
                job = pending.pop()
                running[self._pool.submit(fn, job)] = job
            done, _ = wait(list(running), return_when=FIRST_COMPLETED)
            broken: list[Any] = []
            for future in done:
                job = running.pop(future)
                try:
                    output = future.result()
                except BrokenProcessPool:
                    broken.append(job)
                    continue
                on_result(job, output)
            if broken:
                broken += list(running.values())  # every job in flight died with the pool
                running.clear()
                self._pool.shutdown(wait=False, cancel_futures=True)
                self._pool = self._new_pool()
                log(f"a worker process died; rerunning {len(broken)} job(s) that were in flight")
                for job in sorted(broken, key=lambda j: -j.index):
                    retries[id(job)] = retries.get(id(job), 0) + 1  # by object: indices may repeat
                    if retries[id(job)] > self.max_retries:
                        error = f"{job.obj.object_id}: its worker died {self.max_retries + 1} times; skipped"
                        on_result(job, JobOutput(job.index, {}, {}, error=error))
                    else:
                        pending.append(job)

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None


class RayExecutor:
    """The same jobs as Ray tasks: ``address=None`` starts a local Ray instance with ``workers`` CPUs,
    ``address="auto"`` or ``"ray://host:10001"`` joins a cluster (``pip install 'tognet[ray]'``)."""

    def __init__(self, workers: int | None = None, address: str | None = None, max_retries: int = 3) -> None:
        try:
            import ray
        except ImportError as exc:
            from tognet.errors import TognetError

            raise TognetError("--ray needs Ray: pip install 'tognet[ray]'") from exc
        self._ray = ray
        self.max_retries = max_retries
        self._started = False
        if not ray.is_initialized():
            kwargs: dict[str, Any] = {"include_dashboard": False, "logging_level": "warning",
                                      "log_to_driver": False}
            if address is None:
                kwargs["num_cpus"] = default_workers() if workers is None else int(workers)
            ray.init(address=address, **kwargs)
            self._started = True
        self.workers = int(ray.cluster_resources().get("CPU", 1))
        self._remotes: dict[JobFn, Any] = {}

    def run(self, jobs: list[Any], on_result: OnResult, log: Callable[[str], None], fn: JobFn
            ) -> None:
        ray = self._ray
        if fn not in self._remotes:
            self._remotes[fn] = ray.remote(num_cpus=1, max_retries=self.max_retries)(fn)
        remote = self._remotes[fn]
        pending = list(reversed(jobs))
        running: dict[Any, Any] = {}
        while pending or running:
            while pending and len(running) < 2 * self.workers:
                job = pending.pop()
                running[remote.remote(job)] = job
            ready, _ = ray.wait(list(running), num_returns=1)
            for ref in ready:
                job = running.pop(ref)
                try:
                    output = ray.get(ref)
                except Exception as exc:  # the task failed on every retry (worker crashes, node lost)
                    log(f"job {job.index} ({job.obj.object_id}) failed on Ray: {type(exc).__name__}")
                    output = JobOutput(job.index, {}, {}, error=f"{job.obj.object_id}: Ray task failed "
                                       f"{self.max_retries + 1} times ({type(exc).__name__})")
                on_result(job, output)

    def close(self) -> None:
        if self._started:
            self._ray.shutdown()
            self._started = False


def make_executor(workers: int | None = None, ray: bool = False, ray_address: str | None = None) -> Executor:
    """Local processes, or Ray when ``ray`` or ``ray_address`` is given."""
    if ray or ray_address:
        return RayExecutor(workers, ray_address)
    return LocalExecutor(workers)

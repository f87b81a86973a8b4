"""Where jobs run: local worker processes by default, a Ray cluster when one machine is not enough.

Both executors run a module-level job function ``fn`` (collection's ``run_job``, the evaluation's
``run_eval_job``, ...) on each job and hand each :class:`JobOutput` to the coordinator's callback as
it arrives (in completion order; shards are named by job, so the order does not matter). A worker that
dies (killed, out of memory, a crash inside MuJoCo) is reported and its jobs run again, up to
``max_retries`` times; after that the job is reported as failed and the round goes on. On Ray the
nodes need not share the coordinator's folders (:mod:`tognet.jobs.files`).
"""

from __future__ import annotations

import multiprocessing
import os
import signal
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from typing import Any, Protocol

from tognet.errors import TognetError
from tognet.jobs.files import FileShipError, FileShipper, run_shipped
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
    SIGKILL), so no orphan keeps a core busy; a spawned worker otherwise waits on its queue for ever.
    Ctrl-C is the coordinator's to handle (it stops the workers): the worker ignores SIGINT. SIGTERM
    (how the pool ends a worker) is unblocked again: the worker was started with both held back."""
    import threading
    import time

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT, signal.SIGTERM})

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
        running: dict[Future[JobOutput], Any] = {}
        if self._pool is None:
            self._pool = self._new_pool()
        try:
            self._run(pending, running, on_result, log, fn)
        except KeyboardInterrupt:  # Ctrl-C or SIGTERM: the jobs in flight are dropped, not waited for
            self._stop_workers()
            raise

    def _stop_workers(self, grace: float = 5.0) -> None:
        """End the pool's processes now (their jobs' results would be thrown away). The waits are
        bounded: a pool whose internal threads are stuck (a queue left half-written by a killed worker)
        must not keep an interrupted command from ending."""
        if self._pool is None:
            return
        pool, self._pool = self._pool, None
        procs = list(getattr(pool, "_processes", {}).values())
        for proc in procs:
            proc.kill()
        pool.shutdown(wait=False, cancel_futures=True)
        for proc in procs:
            proc.join(grace)
        manager = getattr(pool, "_executor_manager_thread", None)
        if manager is not None:
            manager.join(grace)

    def _submit(self, fn: JobFn, job: Any) -> Future[JobOutput]:
        """Submit with Ctrl-C and SIGTERM held back: a worker the pool starts here inherits them blocked
        (it never dies of a Ctrl-C half-way through its start), and a signal that arrives meanwhile is
        raised in the coordinator just after."""
        assert self._pool is not None
        held = {signal.SIGINT, signal.SIGTERM}
        old = signal.pthread_sigmask(signal.SIG_BLOCK, held)
        try:
            return self._pool.submit(fn, job)
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, old)

    def _run(self, pending: list[Any], running: dict[Future[JobOutput], Any], on_result: OnResult,
             log: Callable[[str], None], fn: JobFn) -> None:
        assert self._pool is not None
        retries: dict[int, int] = {}
        while pending or running:
            while pending and len(running) < 2 * self.workers:
                job = pending.pop()
                running[self._submit(fn, job)] = job
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
    ``address="auto"``, ``"HOST:6379"`` or ``"ray://HOST:10001"`` joins a cluster
    (``pip install 'tognet[ray]'``).

    On a cluster the nodes need not see the coordinator's files: each job's objects and checkpoints
    travel through Ray's object store, by content (:mod:`tognet.jobs.files`); a local instance reads
    them where they are. A job lost with its worker or its node is
    rerun elsewhere, up to ``max_retries`` times, and the log names it; while no node with CPUs is left,
    the run waits for one and says so."""

    def __init__(self, workers: int | None = None, address: str | None = None, max_retries: int = 3,
                 wait_seconds: float = 30.0) -> None:
        try:
            import ray
        except ImportError as exc:
            raise TognetError("--ray needs Ray: pip install 'tognet[ray]'") from exc
        self._ray = ray
        self.max_retries = max_retries
        self.wait_seconds = wait_seconds
        self._started = False
        self._ship = address is not None
        if not ray.is_initialized():
            self._init(address, workers)
        self.workers = self._cpus()
        self._remote: Any = None

    def _init(self, address: str | None, workers: int | None) -> None:
        kwargs: dict[str, Any] = {"include_dashboard": False, "logging_level": "warning",
                                  "log_to_driver": False}
        if address is None:
            kwargs["num_cpus"] = default_workers() if workers is None else int(workers)
        try:
            self._ray.init(address=address, **kwargs)
        except (ConnectionError, RuntimeError, ValueError) as exc:
            raise TognetError(f"cannot join the Ray cluster at {address}: {exc}") from exc
        self._started = True

    def _cpus(self) -> int:
        """CPUs of the cluster's live nodes (at least 1: the in-flight window is twice this)."""
        return max(1, int(self._ray.cluster_resources().get("CPU", 0)))

    def run(self, jobs: list[Any], on_result: OnResult, log: Callable[[str], None], fn: JobFn
            ) -> None:
        ray = self._ray
        if self._remote is None:
            self._remote = ray.remote(num_cpus=1, max_retries=0)(run_shipped)
        self.workers = self._cpus()
        shipper = FileShipper(ray.put)
        pending = list(reversed(jobs))  # popped from the end: in job order
        attempts: dict[int, int] = {}
        running: dict[Any, Any] = {}
        idle_said = False
        try:
            while pending or running:
                while pending and len(running) < 2 * self.workers:
                    job = pending.pop()
                    try:
                        manifest = shipper.manifest(job) if self._ship else {}
                        running[self._remote.remote(fn, job, manifest)] = job
                    except FileShipError as exc:
                        on_result(job, JobOutput(job.index, {}, {}, error=f"{job.obj.object_id}: {exc}"))
                ready, _ = ray.wait(list(running), num_returns=1, timeout=self.wait_seconds)
                if not ready:
                    idle_said = self._say_if_idle(log, len(running) + len(pending), idle_said)
                    continue
                for ref in ready:
                    job = running.pop(ref)
                    output = self._output(ref, job, attempts, log)
                    if output is None:
                        pending.append(job)
                    else:
                        on_result(job, output)
        finally:
            shipper.release()

    def _output(self, ref: Any, job: Any, attempts: dict[int, int], log: Callable[[str], None]
                ) -> JobOutput | None:
        """The job's output, or None when it was lost with its worker or node and is to run again."""
        ray = self._ray
        try:
            return ray.get(ref)
        except ray.exceptions.RayTaskError as exc:  # the job itself raised: running it again gives the same
            cause = exc.cause if exc.cause is not None else exc
            return JobOutput(job.index, {}, {}, error=f"{job.obj.object_id}: {type(cause).__name__}: {cause}")
        except Exception as exc:  # its worker crashed or its node was lost
            n = attempts[id(job)] = attempts.get(id(job), 0) + 1  # by object: indices may repeat
            reason = type(exc).__name__
            if n > self.max_retries:
                log(f"job {job.index} ({job.obj.object_id}) lost {n} times ({reason}); skipped")
                return JobOutput(job.index, {}, {}, error=f"{job.obj.object_id}: lost with its Ray worker "
                                 f"or node {n} times ({reason})")
            log(f"job {job.index} ({job.obj.object_id}) was lost with its worker or node ({reason}); "
                f"rerunning it (attempt {n + 1} of {self.max_retries + 1})")
            return None

    def _say_if_idle(self, log: Callable[[str], None], waiting: int, said: bool) -> bool:
        """Says once that no node with CPUs is left (the jobs wait for one); returns whether it has."""
        cpus = int(self._ray.cluster_resources().get("CPU", 0))
        if cpus == 0 and not said:
            log(f"no node with CPUs is left in the Ray cluster: {waiting} job(s) wait for one to join "
                "(ray start --address=...)")
        return cpus == 0

    def close(self) -> None:
        if self._started:
            self._ray.shutdown()
            self._started = False


def make_executor(workers: int | None = None, ray: bool = False, ray_address: str | None = None) -> Executor:
    """Local processes, or Ray when ``ray`` or ``ray_address`` is given."""
    if ray or ray_address:
        return RayExecutor(workers, ray_address)
    return LocalExecutor(workers)

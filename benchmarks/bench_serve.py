"""The planning service under load (issue 32): latency against the in-process API, throughput and tail
latency from concurrent clients, memory after many requests; everything on 127.0.0.1, bounded in count and
time.

    .venv/bin/python benchmarks/bench_serve.py [--requests 10000] [--clients 4] [--latency 100]
                                               [--max-seconds 1800] [--method M]

The image: the simulator's hammering scene with the T hammer (a 16-bit PNG and its intrinsics, no pose).
1. **Latency**: ``--latency`` plans in turn, alternating between ``tognet.plan`` in this process and one
   client of ``tognet serve --threads 1`` (both pinned to the same one core, torch on one thread): the
   medians and their ratio (the service's cost: the request, the form, the JSON).
2. **Load**: ``--clients`` client threads send ``--requests`` plans in all (or until ``--max-seconds``):
   throughput, p50 / p99 latency, failed requests; the server's resident memory (VmRSS) after the first
   100 requests and at the end.
"""

from __future__ import annotations

import argparse
import os
import platform
import re
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np


def _image(folder: Path) -> tuple[Path, Path]:
    from tognet.objects.handmade import make_test_tools
    from tognet.planning.camera import save_depth_png, save_intrinsics
    from tognet.sim import SimConfig, Simulator

    tools = make_test_tools(folder / "tools")
    obs = Simulator(SimConfig(), "hammering", tools["t_hammer"]).reset(3)
    k = save_intrinsics(folder / "k.json", obs.camera.intrinsics)
    return save_depth_png(folder / "d.png", obs.depth), k


def _start(threads: int, core: int | None) -> tuple[subprocess.Popen[str], str]:
    exe = Path(sys.executable).with_name("tognet")
    pin = (lambda: os.sched_setaffinity(0, {core})) if core is not None else None
    proc = subprocess.Popen([str(exe), "serve", "--port", "0", "--threads", str(threads), "--preload",
                             "hammering", "--timeout", "60"], stderr=subprocess.PIPE, text=True,
                            preexec_fn=pin)
    assert proc.stderr is not None
    for line in proc.stderr:
        found = re.search(r"listening on (http://127\.0\.0\.1:\d+)", line)
        if found:
            return proc, found.group(1)
    raise RuntimeError("tognet serve did not start")


def _rss_mb(pid: int) -> float:
    text = Path(f"/proc/{pid}/status").read_text()
    return int(re.search(r"VmRSS:\s+(\d+) kB", text).group(1)) / 1024  # type: ignore[union-attr]


def latency(depth: Path, intr: Path, n: int, method: str | None) -> None:
    import torch

    import tognet
    from tognet.serve import Client

    core = min(os.sched_getaffinity(0))
    os.sched_setaffinity(0, {core})
    torch.set_num_threads(1)
    proc, url = _start(1, core)
    try:
        client = Client(url)
        local, remote = [], []
        for i in range(n + 5):
            t0 = time.perf_counter()
            tognet.plan(depth, intr, task="hammering", method=method)
            t1 = time.perf_counter()
            client.plan(depth, intr, task="hammering", method=method)
            t2 = time.perf_counter()
            if i >= 5:
                local.append(t1 - t0)
                remote.append(t2 - t1)
        lo, re_ = 1000 * np.median(local), 1000 * np.median(remote)
        print(f"latency, one core, {n} plans each, interleaved: in-process median {lo:.1f} ms, service "
              f"median {re_:.1f} ms (p90 {1000 * np.percentile(remote, 90):.1f}); ratio {re_ / lo:.2f}",
              flush=True)
    finally:
        os.kill(proc.pid, signal.SIGTERM)
        proc.wait(30)
        os.sched_setaffinity(0, set(range(os.cpu_count() or 1)))


def load(depth: Path, intr: Path, requests: int, clients: int, max_seconds: float, method: str | None
         ) -> None:
    from tognet.serve import Client

    proc, url = _start(0, None)
    times: list[float] = []
    failures: list[str] = []
    lock = threading.Lock()
    rss: dict[str, float] = {}
    sent = [0]
    stop = time.perf_counter() + max_seconds

    def worker() -> None:
        client = Client(url, timeout=120)
        while True:
            with lock:
                if sent[0] >= requests or time.perf_counter() > stop:
                    return
                sent[0] += 1
                if sent[0] == 101:
                    rss["after 100"] = _rss_mb(proc.pid)
            t0 = time.perf_counter()
            try:
                client.plan(depth, intr, task="hammering", method=method, top=0)
            except Exception as exc:  # noqa: BLE001 (every failure is counted)
                with lock:
                    failures.append(str(exc)[:100])
                continue
            with lock:
                times.append(time.perf_counter() - t0)

    try:
        t0 = time.perf_counter()
        pool = [threading.Thread(target=worker) for _ in range(clients)]
        for t in pool:
            t.start()
        for t in pool:
            t.join()
        wall = time.perf_counter() - t0
        rss["at the end"] = _rss_mb(proc.pid)
        ms = 1000 * np.array(times)
        print(f"load, {clients} clients, server on {os.cpu_count()} cores (--threads 0): {len(times)} plans "
              f"in {wall:.0f} s, {len(times) / wall:.1f} plans/s; latency p50 {np.median(ms):.0f} ms, p99 "
              f"{np.percentile(ms, 99):.0f} ms; {len(failures)} failed"
              + (f" (first: {failures[0]})" if failures else ""), flush=True)
        print("server memory (VmRSS): " + ", ".join(f"{k} {v:.0f} MB" for k, v in rss.items())
              + (f"; growth {rss['at the end'] - rss['after 100']:+.0f} MB" if "after 100" in rss else ""))
    finally:
        os.kill(proc.pid, signal.SIGTERM)
        proc.wait(30)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--requests", type=int, default=10_000)
    ap.add_argument("--clients", type=int, default=4)
    ap.add_argument("--latency", type=int, default=100, help="plans each for the latency comparison")
    ap.add_argument("--max-seconds", type=float, default=1800.0,
                    help="the load phase stops here at the latest")
    ap.add_argument("--method", default=None, help="a method a robot can run (default: tognet plan's)")
    args = ap.parse_args()
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} cpus, load average "
          f"{os.getloadavg()[0]:.2f}", flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        depth, intr = _image(Path(tmp))
        if args.latency:
            latency(depth, intr, args.latency, args.method)
        if args.requests:
            load(depth, intr, args.requests, args.clients, args.max_seconds, args.method)
    print(f"load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()

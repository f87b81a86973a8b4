"""A real Ray cluster on this machine whose worker nodes cannot see the run folder (issue 31).

The cluster (:mod:`tognet.jobs.localcluster`) has a head with no CPUs and worker nodes in their own mount
namespace with a tmpfs over the run folder, all in a private network namespace on 127.0.0.1. The tests run
the ``tognet`` command as a user would, once with local workers and once on the cluster, and compare what
they write. Skipped with the reason where root, unshare/nsenter or Ray are missing.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tognet.jobs.localcluster import LocalCluster, unavailable

REASON = unavailable()
pytestmark = pytest.mark.skipif(REASON is not None, reason=f"the blind-node Ray cluster {REASON}")

TOGNET = str(Path(sys.executable).parent / "tognet")
MODELS = Path(__file__).resolve().parents[1] / "tognet" / "models"


def _setup_run(run: Path) -> None:
    from tognet.collect.config import CollectConfig
    from tognet.objects import generate_set

    generate_set("primitive", "train", 3, run / "objs")
    (run / "models").mkdir()
    for name in ("grasping", "hammering", "hammering_search"):
        shutil.copy(MODELS / f"{name}.pt", run / "models" / f"{name}.pt")  # the nodes cannot see these
    CollectConfig(trials_per_scene=3, scenes_per_job=1).save(run / "small.json")
    CollectConfig(trials_per_scene=3, scenes_per_job=4).save(run / "long.json")


@pytest.fixture(scope="module")
def cluster(tmp_path_factory) -> Iterator[tuple[LocalCluster, Path]]:
    run = tmp_path_factory.mktemp("cluster-run")
    _setup_run(run)
    fast_failure = {"RAY_health_check_period_ms": "1000", "RAY_health_check_failure_threshold": "3"}
    c = LocalCluster([run], env=fast_failure)  # a lost node noticed in ~3 s, not ~15
    try:
        c.start()
        c.add_node(2, c.temp / "cache-0")
        yield c, run
    finally:
        c.close()


def _tognet(args: list[str], cluster: LocalCluster | None = None, timeout: float = 600) -> str:
    """Run the tognet command (on the cluster when given: a driver in its network namespace)."""
    cmd = [TOGNET, *args]
    env = None
    if cluster is not None:
        cmd, env = cluster.command([*cmd, "--ray-address", cluster.address]), cluster.env
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env)
    assert done.returncode == 0, f"{' '.join(cmd)}\n{done.stdout}\n{done.stderr[-3000:]}"
    return done.stdout


def _collect_args(run: Path, out: str, episodes: int, config: str) -> list[str]:
    return ["collect", "--task", "hammering", "--objects", str(run / "objs"), "--out", str(run / out),
            "--episodes", str(episodes), "--policy", "epsilon_greedy", "--no-progress",
            "--grasp-model", str(run / "models" / "grasping.pt"),
            "--task-model", str(run / "models" / "hammering.pt"), "--config", str(run / config)]


def _same_records(a: Path, b: Path) -> int:
    from tognet.data.episodes import read_dataset
    from tognet.data.format import FIELDS

    first, second = read_dataset(a, keep_invalid=True), read_dataset(b, keep_invalid=True)
    assert len(first.z) == len(second.z) > 0
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(first, name), getattr(second, name), err_msg=name)
    return len(first.z)


def _cached_digests(cache: Path) -> set[str]:
    from tognet.io import sha256_file

    return {sha256_file(f) for f in cache.rglob("*") if f.is_file() and not f.name.startswith(".")}


def _needed_digests(run: Path, models: list[str]) -> set[str]:
    from tognet.io import sha256_file
    from tognet.objects import load_catalog

    files = [o.path(n) for o in load_catalog(run / "objs") for n in o.file_names]
    return {sha256_file(f) for f in files + [run / "models" / f"{m}.pt" for m in models]}


def test_the_worker_node_cannot_see_the_run_folder(cluster):
    c, run = cluster
    path = repr(str(run / "small.json"))
    probe = ("import os, ray\nray.init(address='127.0.0.1:6379', logging_level='error')\n"
             "f = ray.remote(num_cpus=1)(lambda p: os.path.exists(p))\n"
             f"print(ray.get(f.remote({path})), os.path.exists({path}))")
    done = subprocess.run(c.command([sys.executable, "-c", probe]), capture_output=True, text=True, env=c.env,
                          timeout=120)
    assert done.stdout.split() == ["False", "True"], done.stderr[-2000:]


def test_a_collection_round_on_blind_nodes_writes_the_records_local_workers_write(cluster):
    c, run = cluster
    _tognet(_collect_args(run, "local", 9, "small.json") + ["--workers", "1"])
    out = _tognet(_collect_args(run, "cluster", 9, "small.json"), c)
    assert "2 workers" in out
    assert _same_records(run / "local", run / "cluster") == 9
    # every object file and both checkpoints reached the node through Ray, by content
    assert _needed_digests(run, ["grasping", "hammering"]) <= _cached_digests(c.temp / "cache-0")


def _comparable(results: dict[str, Any]) -> dict[str, Any]:
    """results.json without what differs between two runs of the same evaluation: timings, the folder."""
    def strip(x: Any) -> Any:
        if isinstance(x, dict):
            return {k: strip(v) for k, v in x.items()
                    if k not in ("run", "timing") and not k.endswith("_seconds")}
        return [strip(v) for v in x] if isinstance(x, list) else x
    return strip(results)


def test_an_evaluation_on_blind_nodes_gives_the_results_local_workers_give(cluster):
    c, run = cluster
    models = run / "models"
    args = ["evaluate", "--task", "hammering", "--category", "pg-primitive", "--episodes", "4",
            "--methods", "TOG-Net,TOG-Net+ActionSearch", "--grasp-model", str(models / "grasping.pt"),
            "--task-model", f"hammering={models / 'hammering.pt'}",
            "--task-model", f"hammering_search={models / 'hammering_search.pt'}", "--no-progress"]
    _tognet(args + ["--out", str(run / "eval-local"), "--workers", "1"])
    _tognet(args + ["--out", str(run / "eval-cluster")], c)
    local, remote = (json.loads((run / f / "results.json").read_text())
                     for f in ("eval-local", "eval-cluster"))
    text = json.dumps(_comparable(remote)).replace("eval-cluster", "eval-local")
    assert json.loads(text) == _comparable(local)
    # the report's animations were made on the node and written by the coordinator
    gifs = sorted(p.name for p in (run / "eval-local" / "gifs").glob("*.gif"))
    assert gifs and gifs == sorted(p.name for p in (run / "eval-cluster" / "gifs").glob("*.gif"))


def test_a_pipeline_on_blind_nodes_collects_and_trains_what_local_workers_do(cluster):
    c, run = cluster
    args = ["pipeline", "--task", "hammering", "--preset", "ci", "--no-progress"]
    _tognet(args + ["--out", str(run / "pipe-local"), "--workers", "1"])
    _tognet(args + ["--out", str(run / "pipe-cluster")], c)
    rounds = sorted(p.relative_to(run / "pipe-local") for p in (run / "pipe-local").glob("*/round*/data"))
    assert len(rounds) == 4  # the grasp-only round and three of hammering, each trained on
    for data in rounds:
        _same_records(run / "pipe-local" / data, run / "pipe-cluster" / data)


def test_a_node_lost_mid_round_costs_nothing_and_the_log_names_the_rerun_jobs(cluster):
    c, run = cluster
    args = _collect_args(run, "killed", 96, "long.json")  # 8 jobs of 12 trials
    _tognet([*args[:args.index("--out") + 1], str(run / "uninterrupted"), *args[args.index("--out") + 2:],
             "--workers", "1"])
    node = c.nodes[-1]
    cmd = c.command([TOGNET, *args, "--ray-address", c.address])
    driver = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=c.env)
    try:
        deadline = time.monotonic() + 300
        while not list((run / "killed").glob("shard-*.npz")):
            assert driver.poll() is None and time.monotonic() < deadline, "the round ended before any shard"
            time.sleep(0.05)
        c.kill_node(node)
        assert len(list((run / "killed").glob("shard-*.npz"))) < 8, "the round finished before the kill"
        c.add_node(2, c.temp / "cache-1")
        log, _ = driver.communicate(timeout=600)
    finally:
        if driver.poll() is None:
            driver.kill()
    assert driver.returncode == 0, log[-3000:]
    assert _same_records(run / "uninterrupted", run / "killed") == 96
    rerun = [line for line in log.splitlines() if "rerunning it (attempt 2 of 4)" in line]
    assert rerun and all("primitive-train-" in line for line in rerun), log[-3000:]
    assert _needed_digests(run, ["grasping", "hammering"]) <= _cached_digests(c.temp / "cache-1")

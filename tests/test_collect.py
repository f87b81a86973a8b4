"""Self-supervised collection on real small runs: determinism, replay, crash safety, bad objects."""

from __future__ import annotations

import dataclasses
import json
import os
import shutil
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from tognet.collect.config import CollectConfig, RoundConfig
from tognet.collect.jobs import plan_jobs, run_job
from tognet.collect.rounds import collect_round
from tognet.collect.store import RoundStore
from tognet.data.episodes import read_dataset
from tognet.data.format import FIELDS, DatasetError
from tognet.geometry import Grasp
from tognet.jobs.workers import LocalExecutor
from tognet.objects import generate_set
from tognet.sim import SimConfig, Simulator

SMALL = CollectConfig(trials_per_scene=3, scenes_per_job=1)


@pytest.fixture(scope="module")
def objects(tmp_path_factory):
    return generate_set("primitive", "train", 3, tmp_path_factory.mktemp("objects"))


def _arrays(folder: Path) -> dict[str, np.ndarray]:
    ep = read_dataset(folder, keep_invalid=True)
    return {name: getattr(ep, name) for name in FIELDS}


def _same(a: dict[str, np.ndarray], b: dict[str, np.ndarray]) -> None:
    assert len(a["z"]) == len(b["z"]) > 0
    for name in FIELDS:
        np.testing.assert_array_equal(a[name], b[name], err_msg=name)


def test_job_is_deterministic_and_its_records_replay(objects):
    job = plan_jobs("sweeping", 1, objects, 3, "nms_uniform", SMALL)[0]
    first, again = run_job(job), run_job(job)
    assert first.error is None and len(first.columns["z"]) == 3
    for name, col in first.columns.items():
        np.testing.assert_array_equal(col, again.columns[name], err_msg=name)
    # a stored record replays: same scene seed, the stored (float32) grasp and action, seed = trial
    c = first.columns
    sim = Simulator(SimConfig(), "sweeping", job.obj)
    sim.reset(int(c["scene_seed"][0]))
    for k in range(3):
        grasp = Grasp.from_array(c["grasp"][k].astype(np.float64))
        res = sim.execute(grasp, c["action"][k].astype(np.float64), seed=int(c["trial"][k]))
        assert (res.grasp_success, res.task_success, res.failure.value) == (
            bool(c["grasp_success"][k]), bool(c["task_success"][k]), str(c["failure"][k]))
        assert c["lift_tilt"][k] == pytest.approx(res.info.get("lift_tilt", -1.0), rel=1e-6)
    assert c["crop"].dtype == np.float16 and np.all(np.isfinite(c["crop"].astype(np.float32)))


def test_round_killed_with_sigkill_resumes_to_the_same_records(objects, tmp_path):
    """The coordinator process is SIGKILLed after some shards; the resumed round equals an uninterrupted
    one: the same records, no duplicate, no gap."""
    rc = RoundConfig(episodes=18, policy="nms_uniform")
    reference = tmp_path / "reference"
    collect_round("hammering", 1, objects, rc, SMALL, reference, executor=LocalExecutor(0), progress=False,
                  log=lambda _m: None)
    killed = tmp_path / "killed"
    script = textwrap.dedent(f"""
        import time
        from tognet.collect.config import CollectConfig, RoundConfig
        from tognet.collect.rounds import collect_round
        from tognet.jobs.workers import LocalExecutor
        from tognet.objects import load_catalog
        objects = load_catalog({str(Path(objects[0].folder).parent)!r})
        slow = LocalExecutor(0)
        run = slow.run
        def paced(jobs, on_result, log, fn):
            def late(job, out):
                on_result(job, out)
                time.sleep(0.5)
            run(jobs, late, log, fn)
        slow.run = paced
        collect_round("hammering", 1, objects, RoundConfig(episodes=18, policy="nms_uniform"),
                      CollectConfig(trials_per_scene=3, scenes_per_job=1), {str(killed)!r}, executor=slow,
                      progress=False, log=print)
    """)
    proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.time() + 120
    while time.time() < deadline and len(list(killed.glob("shard-*.npz"))) < 2:
        time.sleep(0.05)
    os.kill(proc.pid, signal.SIGKILL)
    err = proc.communicate()[1].decode()
    assert "Traceback" not in err, err
    written = len(list(killed.glob("shard-*.npz")))
    assert 2 <= written < 6, f"the kill came too late to test anything ({written} of 6 shards)"
    collect_round("hammering", 1, objects, rc, SMALL, killed, executor=LocalExecutor(0), progress=False,
                  log=lambda _m: None)
    _same(_arrays(reference), _arrays(killed))
    manifest = json.loads((killed / "manifest.json").read_text())
    assert [s["meta"]["job"] for s in manifest["shards"]] == list(range(6))


class _KillOneWorker(LocalExecutor):
    """Local workers; after the first result, one worker process is SIGKILLed (mid-job)."""

    def run(self, jobs, on_result, log, fn):
        killed = []

        def then_kill(job, output):
            on_result(job, output)
            if not killed and self._pool is not None and self._pool._processes:
                pid = next(iter(self._pool._processes))
                os.kill(pid, signal.SIGKILL)
                killed.append(pid)

        super().run(jobs, then_kill, log, fn)
        self.killed = killed


def test_a_killed_worker_is_reported_and_its_jobs_rerun(objects, tmp_path):
    rc = RoundConfig(episodes=12, policy="nms_uniform")
    reference, other = tmp_path / "reference", tmp_path / "other"
    collect_round("sweeping", 1, objects, rc, SMALL, reference, executor=LocalExecutor(0), progress=False,
                  log=lambda _m: None)
    messages: list[str] = []
    executor = _KillOneWorker(1)
    try:
        collect_round("sweeping", 1, objects, rc, SMALL, other, executor=executor, progress=False,
                      log=messages.append)
    finally:
        executor.close()
    assert executor.killed and any("worker process died" in m for m in messages)
    _same(_arrays(reference), _arrays(other))


def test_bad_object_is_skipped_and_the_round_goes_on(objects, tmp_path):
    """An object whose collision mesh is garbage (MuJoCo rejects it) costs its job, not the round."""
    folder = tmp_path / "broken-object"
    shutil.copytree(objects[1].folder, folder)
    (folder / objects[1].collision_meshes[0]).write_bytes(b"solid garbage\nnot a mesh at all")
    broken = dataclasses.replace(objects[1], folder=str(folder), object_id="broken-object")
    summary = collect_round("sweeping", 1, [objects[0], broken], RoundConfig(episodes=6), SMALL,
                            tmp_path / "d", executor=LocalExecutor(0), progress=False, log=lambda _m: None)
    assert len(summary["errors"]) == 1 and "broken-object" in summary["errors"][0]
    assert summary["episodes"] == 3  # the good object's job


def test_corrupt_shard_is_named_and_an_unlisted_one_set_aside(objects, tmp_path):
    folder = tmp_path / "d"
    collect_round("sweeping", 1, objects, RoundConfig(episodes=6), SMALL, folder, executor=LocalExecutor(0),
                  progress=False, log=lambda _m: None)
    shard = folder / "shard-000001.npz"
    shard.write_bytes(shard.read_bytes()[: shard.stat().st_size // 2])
    with pytest.raises(DatasetError, match="shard-000001.npz.*(corrupt|truncated)"):
        read_dataset(folder)
    # a shard the manifest does not list yet (a kill between rename and manifest) that is corrupt: set
    # aside, never deleted, and its job runs again
    manifest = json.loads((folder / "manifest.json").read_text())
    manifest["shards"] = [s for s in manifest["shards"] if s["file"] != shard.name]
    (folder / "manifest.json").write_text(json.dumps(manifest))
    meta = manifest["collection"]
    with pytest.warns(UserWarning, match="moved aside"):
        store = RoundStore(folder, "sweeping", {k: v for k, v in meta.items() if k != "task"})
    assert 1 not in store.done and (folder / "shard-000001.npz.corrupt").is_file()


def test_reopening_with_other_settings_is_refused(objects, tmp_path):
    folder = tmp_path / "d"
    collect_round("sweeping", 1, objects, RoundConfig(episodes=3), SMALL, folder, executor=LocalExecutor(0),
                  progress=False, log=lambda _m: None)
    other = dataclasses.replace(SMALL, seed=1)
    with pytest.raises(DatasetError, match="another collection.*config_hash"):
        collect_round("sweeping", 1, objects, RoundConfig(episodes=3), other, folder,
                      executor=LocalExecutor(0), progress=False, log=lambda _m: None)


def test_ray_and_local_workers_write_identical_records(objects, tmp_path):
    """The same jobs through a local Ray instance (started by the test) and through local processes."""
    pytest.importorskip("ray")
    from tognet.jobs.workers import RayExecutor

    rc = RoundConfig(episodes=9, policy="nms_uniform")
    local = LocalExecutor(1)
    try:
        collect_round("hammering", 1, objects, rc, SMALL, tmp_path / "local", executor=local, progress=False,
                      log=lambda _m: None)
    finally:
        local.close()
    ray_executor = RayExecutor(workers=2)
    try:
        summary = collect_round("hammering", 1, objects, rc, SMALL, tmp_path / "ray", executor=ray_executor,
                                progress=False, log=lambda _m: None)
    finally:
        ray_executor.close()
    assert summary["workers"] == 2
    _same(_arrays(tmp_path / "local"), _arrays(tmp_path / "ray"))


def test_workers_end_when_their_coordinator_is_killed(tmp_path):
    """A coordinator SIGKILLed with its worker pool up leaves no orphan worker behind."""
    script = textwrap.dedent("""
        import os, time
        from tognet.jobs.workers import LocalExecutor
        ex = LocalExecutor(1)
        pool = ex._new_pool()
        pool.submit(os.getpid).result()
        print(*pool._processes, flush=True)
        time.sleep(60)
    """)
    proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    worker = int(proc.stdout.readline())
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    deadline = time.time() + 15
    while time.time() < deadline and Path(f"/proc/{worker}").exists():
        status = Path(f"/proc/{worker}/status").read_text() if Path(f"/proc/{worker}").exists() else ""
        if "State:\tZ" in status:
            break
        time.sleep(0.2)
    alive = Path(f"/proc/{worker}").exists() and "State:\tZ" not in Path(f"/proc/{worker}/status").read_text()
    assert not alive, "the worker outlived its coordinator"


def test_two_nms_rankings_on_one_scene_keep_their_own_modes():
    """The antipodal ranking and a Q_G ranking share a SceneView's cache without reading each other's."""
    from types import SimpleNamespace

    from tognet.grasping import AntipodalConfig, CropConfig, prepare_depth, sample_antipodal
    from tognet.grasping.synthetic import Box, render_depth, tilted_camera
    from tognet.policies.config import PolicyConfig
    from tognet.policies.grasp import NMSGrasps
    from tognet.policies.view import SceneView

    camera = tilted_camera(0.9)
    depth = render_depth(camera, [Box.on_table(0.0, 0.0, (0.3, 0.03, 0.03), 0.0)])
    scene = prepare_depth(depth, camera)
    cands = sample_antipodal(scene, None, AntipodalConfig(), np.random.default_rng(0))
    view = SceneView(scene, cands, None, CropConfig())

    class Reversed:  # a Q_G that ranks the candidates the other way round from the antipodal score
        def predict(self, crops, z):
            return SimpleNamespace(q_g=1.0 - view.candidates.quality[: len(z)])

    by_quality, _ = NMSGrasps(PolicyConfig()).modes(view)
    by_model, _ = NMSGrasps(PolicyConfig(), Reversed()).modes(view)
    assert not np.array_equal(by_quality[0], by_model[0])


def test_expert_exploration_uses_the_oracles_actions_and_is_saved_with_the_data(objects, tmp_path):
    from tognet.data.format import ACTION_SOURCES
    from tognet.sim.oracle import task_actions

    expert = RoundConfig(episodes=6, expert_actions=1.0)
    cfg = expert.collect_config(SMALL)
    assert cfg.policy.expert_actions == 1.0 and RoundConfig(episodes=6).collect_config(SMALL) == SMALL
    job = plan_jobs("sweeping", 1, objects, 3, "nms_uniform", cfg)[0]
    out = run_job(job)
    c = out.columns
    assert out.error is None and len(c["z"]) == 3
    assert np.all(c["action_source"] == ACTION_SOURCES["expert"])
    sim = Simulator(SimConfig(), "sweeping", job.obj)
    sim.reset(int(c["scene_seed"][0]))
    for k in range(3):  # each action is one of the oracle's candidates for its grasp, on the settled scene
        cands = np.array(task_actions(sim, Grasp.from_array(c["grasp"][k].astype(np.float64))))
        assert np.min(np.abs(cands - c["action"][k]).max(axis=1)) < 1e-6
    # without it, the round explores uniformly as before
    plain = run_job(plan_jobs("sweeping", 1, objects, 3, "nms_uniform", SMALL)[0]).columns
    assert np.all(plain["action_source"] == ACTION_SOURCES["uniform"])
    # the round's override is what the collection saves beside its data
    collect_round("sweeping", 1, objects[:1], expert, SMALL, tmp_path / "r1", progress=False,
                  log=lambda m: None)
    saved = json.loads(next((tmp_path / "r1" / "configs").glob("collect*.json")).read_text())
    assert saved["policy"]["expert_actions"] == 1.0
    with pytest.raises(ValueError, match="no hand-computed actions"):
        task_actions(Simulator(SimConfig(), "grasping", objects[0]), Grasp(0.0, 0.0, 0.05, 0.0))


def test_a_round_whose_first_jobs_all_fail_stops_and_writes_nothing_for_them(objects, tmp_path):
    """A model every job fails to load is the round's fault, not the objects': stop, and a resume after
    the fix runs those jobs (they are not recorded as done)."""
    from tognet.collect.rounds import RoundError

    bad = tmp_path / "bad.pt"
    bad.write_bytes(b"not a checkpoint")
    with pytest.raises(RoundError, match="all failed.*bad.pt"):
        collect_round("sweeping", 1, objects, RoundConfig(episodes=9), SMALL, tmp_path / "d",
                      grasp_model=bad, executor=LocalExecutor(0), progress=False, log=lambda _m: None)
    assert not list((tmp_path / "d").iterdir())  # no empty dataset left to refuse a fixed run on
    collect_round("sweeping", 1, objects, RoundConfig(episodes=3), SMALL, tmp_path / "d",
                  executor=LocalExecutor(0), progress=False, log=lambda _m: None)  # the fix: no model
    manifest = json.loads((tmp_path / "d" / "manifest.json").read_text())
    assert len(manifest["shards"]) >= 1


def test_a_rounds_policies_are_built_from_its_policy_name_in_one_place(objects):
    """round_policies: exploration for nms_uniform, epsilon-greedy mixes of the model's policies and that
    exploration for epsilon_greedy, expert actions mixed into exploration when asked for (tasks only)."""
    from tognet.collect.jobs import round_policies
    from tognet.policies.action import ExpertActions, NoActions, PolicyActions, UniformActions
    from tognet.policies.grasp import CEMGrasp, NMSGrasps
    from tognet.policies.mix import EpsilonGreedyActions, EpsilonGreedyGrasps, ExpertMixActions

    model, sim = object(), object()
    expert_cfg = RoundConfig(expert_actions=0.25).collect_config(SMALL)

    def job(task, policy, cfg=SMALL):
        return plan_jobs(task, 1, objects, 3, policy, cfg)[0]

    grasps, actions = round_policies(job("sweeping", "nms_uniform"), sim, model)
    assert isinstance(grasps, NMSGrasps) and grasps.grasp_model is model
    assert isinstance(actions, UniformActions)
    grasps, actions = round_policies(job("grasping", "nms_uniform", expert_cfg), sim)
    assert isinstance(grasps, NMSGrasps) and isinstance(actions, NoActions)  # no expert without a task
    _, actions = round_policies(job("sweeping", "nms_uniform", expert_cfg), sim)
    assert isinstance(actions, ExpertMixActions) and isinstance(actions.base, UniformActions)
    assert isinstance(actions.expert, ExpertActions) and actions.expert.sim is sim
    assert actions.probability == 0.25
    grasps, actions = round_policies(job("sweeping", "epsilon_greedy", expert_cfg), sim, None, model)
    p = expert_cfg.policy
    assert isinstance(grasps, EpsilonGreedyGrasps) and grasps.epsilon == p.epsilon_grasp
    assert isinstance(grasps.greedy, CEMGrasp) and grasps.greedy.model is model
    assert isinstance(grasps.explore, NMSGrasps)
    assert isinstance(actions, EpsilonGreedyActions) and actions.epsilon == p.epsilon_action
    assert isinstance(actions.greedy, PolicyActions) and isinstance(actions.explore, ExpertMixActions)
    with pytest.raises(ValueError, match="needs the last round's task model"):
        round_policies(job("sweeping", "epsilon_greedy"), sim)
    with pytest.raises(ValueError, match="unknown round policy 'greedy'"):
        round_policies(job("sweeping", "greedy"), sim)
    with pytest.raises(ValueError, match="search_candidates round needs an action-search model"):
        round_policies(job("sweeping", "search_candidates"), sim, None, model)

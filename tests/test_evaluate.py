"""The evaluation: intervals against published values, the harness at ci scale (results, report, identical
scenes for every method, resume) and the command's errors."""

import hashlib
import json
import re

import numpy as np
import pytest
from eval_testlib import renderer_available, tiny_models
from typer.testing import CliRunner

from tognet.cli import app
from tognet.evaluate import EvalConfig, EvalError, newcombe_paired, paired_difference, run_evaluation, wilson
from tognet.jobs.workers import LocalExecutor
from tognet.objects.record import load_catalog
from tognet.planning import METHODS, BoundConfig, OracleConfig, PlanConfig
from tognet.planning.method_names import DIAGNOSTIC_NAMES
from tognet.sim import Simulator
from tognet.tasks import TASK_NAMES

CONFIG = EvalConfig(scenes_per_job=1, plan=PlanConfig(oracle=OracleConfig(grasps=2, seeds=1, max_trials=12),
                                                      bound=BoundConfig(grasps=2, seeds=1, max_trials=16)))
TASKS = list(TASK_NAMES)  # every registered task
EPISODES = 2


# --- statistics -----------------------------------------------------------------------------------------
@pytest.mark.parametrize("k, n, low, high", [
    (81, 263, 0.2553, 0.3662),  # Newcombe (1998), Stat Med 17:857, Table I: the Wilson score interval
    (15, 148, 0.0624, 0.1605),
    (0, 20, 0.0, 0.1611),
    (1, 29, 0.0061, 0.1718),
])
def test_wilson_interval_matches_published_values(k, n, low, high):
    lo, hi = wilson(k, n)
    assert (round(lo, 4), round(hi, 4)) == (low, high)


def test_wilson_interval_agrees_with_scipy_and_behaves_at_the_ends():
    from scipy.stats import binomtest

    for n in (1, 7, 30, 300):
        for k in sorted({0, 1, n // 3, n // 2, n - 1, n}):
            ci = binomtest(k, n).proportion_ci(method="wilson")
            assert wilson(k, n) == pytest.approx((ci.low, ci.high), abs=1e-9)
    assert wilson(0, 0) == (0.0, 1.0)
    assert wilson(10, 10)[1] == 1.0 and wilson(0, 10)[0] == 0.0
    with pytest.raises(ValueError):
        wilson(5, 4)


def test_paired_difference_matches_a_published_value():
    # Fagerland, Lydersen & Laake, Statistical Analysis of Contingency Tables, ch. 8 (Cavo et al. 2012):
    # the Newcombe square-and-add interval -0.0621 (-0.1186 to -0.0046)
    diff, lo, hi = newcombe_paired(59, 6, 16, 80)
    assert (round(diff, 4), round(lo, 4), round(hi, 4)) == (-0.0621, -0.1186, -0.0046)
    assert newcombe_paired(59, 16, 6, 80) == pytest.approx((-diff, -hi, -lo))  # the other way round
    first = np.array([1] * 59 + [1] * 6 + [0] * 16 + [0] * 80)
    second = np.array([1] * 59 + [0] * 6 + [1] * 16 + [0] * 80)
    d = paired_difference(first, second)
    assert d["pairs"] == 161
    assert (d["both"], d["first_only"], d["second_only"], d["neither"]) == (59, 6, 16, 80)
    assert d["ci"] == pytest.approx([lo, hi])
    same = paired_difference([1, 0, 1, 1], [1, 0, 1, 1])
    assert same["difference"] == 0 and same["ci"][0] < 0 < same["ci"][1]
    assert paired_difference([1] * 50, [0] * 50)["ci"][0] > 0.8


# --- the harness at ci scale ----------------------------------------------------------------------------
@pytest.fixture(scope="module")
def models(tmp_path_factory):
    return tiny_models(tmp_path_factory.mktemp("models"), search=True)


def _run(out, models, **kwargs):
    options = dict(methods="all", categories=["pg-primitive"], episodes=EPISODES, config=CONFIG,
                   grasp_model=models["grasping"],
                   task_models={n: p for n, p in models.items() if n != "grasping"}, progress=False,
                   log=lambda _m: None)
    options.update(kwargs)
    return run_evaluation(out, TASKS, **options)


@pytest.fixture(scope="module")
def evaluation(tmp_path_factory, models):
    out = tmp_path_factory.mktemp("eval")
    executor = LocalExecutor(2)  # the collection's worker processes
    try:
        results = _run(out, models, executor=executor)
    finally:
        executor.close()
    return out, results


def _records(out):
    recs = []
    for file in sorted(out.glob("*/*/job-*.json")):
        recs += json.loads(file.read_text())["records"]
    return recs


def test_results_are_well_formed(evaluation):
    out, results = evaluation
    saved = json.loads((out / "results.json").read_text())
    assert saved["methods"] == list(METHODS)
    assert {m for m, k in saved["kinds"].items() if k == "diagnostic"} == set(DIAGNOSTIC_NAMES)
    for task in TASKS:
        subsets = results["tasks"][task]["categories"]["pg-primitive"]
        assert set(subsets) == ({"mix", "one-can", "two-can"} if task == "sweeping" else {"all"})
        main = subsets["mix" if task == "sweeping" else "all"]
        for m in METHODS:
            s = main["methods"][m]
            assert s["episodes"] == EPISODES and s["valid"] + s["invalid"] == EPISODES
            assert 0 <= s["successes"] <= s["grasp_successes"] <= s["valid"]
            if s["valid"]:
                assert s["rate"] == s["successes"] / s["valid"]
                assert s["ci"][0] <= s["rate"] <= s["ci"][1]
                assert s["ci"] == list(wilson(s["successes"], s["valid"]))
            assert sum(s["failures"].values()) == s["valid"] - s["successes"]
            if m != "TOG-Net":
                d = main["tognet_minus_method"][m]
                assert d["pairs"] <= EPISODES and d["ci"][0] <= d["difference"] <= d["ci"][1]
            if m != "TOG-Net+ActionSearch" and m not in DIAGNOSTIC_NAMES:
                d = main["action_search_minus_method"][m]
                assert d["pairs"] <= EPISODES and d["ci"][0] <= d["difference"] <= d["ci"][1]
        assert not set(main["action_search_minus_method"]) & set(DIAGNOSTIC_NAMES)
        gap = main["gap"]  # where the gap to the Oracle is: the four rows, both halves
        assert list(gap["rates"]) == ["TOG-Net", *DIAGNOSTIC_NAMES, "Oracle"]
        assert {"perfect_motion", "perfect_grasp", "needs_both"} <= set(gap)
        assert "Oracle" not in main["model_rating"] and main["model_rating"]["TOG-Net"]["n"] <= EPISODES
        oracle = main["methods"]["Oracle"]["rate"]
        if oracle:
            assert main["oracle_fraction"]["TOG-Net"] == main["methods"]["TOG-Net"]["rate"] / oracle
        if task == "sweeping":  # the mix is the one-can and the two-can scenes together
            parts = (subsets[k]["methods"]["TOG-Net"]["episodes"] for k in ("one-can", "two-can"))
            assert sum(parts) == EPISODES
        assert results["tasks"][task]["timing"]["TOG-Net"]["total"] > 0
    assert results["run"]["episodes_run_now"] == len(TASKS) * EPISODES * len(METHODS)


def test_the_report_is_self_contained(evaluation):
    out, _ = evaluation
    page = (out / "report.html").read_text()
    sources = re.findall(r"<img src='([^']*)'", page)
    assert len(sources) >= 3 and all(s.startswith("data:image/") for s in sources)  # opens from disk alone
    assert "http://" not in page and "https://" not in page
    for m in METHODS:  # the diagnostics marked as using the simulator
        cell = f"<td class='diag'>{m} †</td>" if m in DIAGNOSTIC_NAMES else f"<td>{m}</td>"
        assert page.count(cell) >= 6
    assert "Where the gap is" in page and "TOG-Net+ActionSearch minus method, paired" in page
    md = (out / "report.md").read_text()
    assert "| method | pg-primitive |" in md
    for link in re.findall(r"\]\(([^)]+\.(?:png|gif))\)", md):
        assert (out / link).is_file()
    gifs = sorted((out / "gifs").glob("*.gif"))
    if renderer_available():  # typical episodes of each method, embedded, playing at the simulated speed
        assert len(gifs) >= len(TASKS) * len(METHODS) and page.count("data:image/gif") == len(gifs)
        from PIL import Image

        im = Image.open(gifs[0])
        delays = []
        for i in range(im.n_frames):
            im.seek(i)
            delays.append(im.info["duration"])
        assert min(delays) >= 20


def test_every_method_ran_on_the_same_scenes(evaluation, models):
    from tognet.evaluate.jobs import state_digest

    out, _ = evaluation
    scenes: dict[tuple, list[dict]] = {}
    for r in _records(out):
        scenes.setdefault((r["task"], r["object_id"], r["scene_seed"]), []).append(r)
    assert len(scenes) == len(TASKS) * EPISODES
    objects = {o.object_id: o for o in load_catalog(out / "objects" / "primitive-test")}
    for (task, object_id, seed), recs in scenes.items():
        assert sorted(r["method"] for r in recs) == sorted(METHODS)
        with_plan = [r for r in recs if r.get("pose")]
        assert len({r["depth_sha"] for r in recs}) == 1  # the same depth image
        # every trial started from the same simulator state (after the Oracle's search trials, too)
        assert len({r["state_sha"] for r in with_plan}) == 1
        poses = np.array([r["pose"] for r in with_plan])
        assert np.abs(poses - poses[0]).max() < 1e-6  # the same object pose
        # and it is the scene a fresh simulator makes from the seed
        sim = Simulator(CONFIG.sim, task, objects[object_id])
        obs = sim.reset(seed)
        digest = hashlib.sha256(np.ascontiguousarray(obs.depth).tobytes()).hexdigest()[:16]
        assert digest == recs[0]["depth_sha"]
        assert state_digest(sim) == with_plan[0]["state_sha"]


def test_a_resumed_evaluation_reruns_exactly_the_missing_jobs(evaluation, models, tmp_path):
    import shutil

    out, results = evaluation
    copy = tmp_path / "eval"
    shutil.copytree(out, copy)
    jobs = sorted(copy.glob("hammering/pg-primitive/job-*.json"))
    jobs[0].unlink()  # a job that never finished
    jobs[1].write_text("{not json")  # a job file torn by a crash
    with pytest.warns(UserWarning, match="moved aside"):
        again = _run(copy, models, resume=True, executor=LocalExecutor(0), report=False)
    assert again["run"]["episodes_run_now"] == 2 * len(METHODS)

    def strip(recs):
        keep = ("method", "object_id", "scene_seed", "grasp", "action", "valid", "grasp_success",
                "task_success", "failure", "pose", "depth_sha", "state_sha")
        return [{k: r.get(k) for k in keep} for r in recs]

    assert strip(_records(copy)) == strip(_records(out))  # the same records as the uninterrupted run
    assert _same_counts(again, results)
    with pytest.raises(EvalError, match="already holds an evaluation"):
        _run(copy, models, executor=LocalExecutor(0), report=False)
    with pytest.raises(EvalError, match="differs in episodes"):
        _run(copy, models, episodes=3, resume=True, executor=LocalExecutor(0), report=False)


def test_a_resume_compares_models_by_content_not_by_path(evaluation, models, tmp_path):
    import shutil

    out, _ = evaluation
    copy = tmp_path / "eval"
    shutil.copytree(out, copy)
    moved = {}
    for name, path in models.items():  # the same files at other paths: the same models
        moved[name] = tmp_path / "elsewhere" / f"{name}.pt"
        moved[name].parent.mkdir(exist_ok=True)
        shutil.copy(path, moved[name])
    again = _run(copy, moved, resume=True, executor=LocalExecutor(0), report=False)
    assert again["run"]["episodes_run_now"] == 0
    settings = json.loads((copy / "evaluation.json").read_text())  # as if started with other weights
    entry = next(v for v in settings["models"].values() if isinstance(v, dict) and "sha256" in v)
    entry["sha256"] = "0" * len(entry["sha256"])
    (copy / "evaluation.json").write_text(json.dumps(settings))
    with pytest.raises(EvalError, match="differs in models"):
        _run(copy, models, resume=True, executor=LocalExecutor(0), report=False)


def _same_counts(a, b):
    def counts(res):
        return {(t, m): (s["methods"][m]["successes"], s["methods"][m]["valid"])
                for t, tr in res["tasks"].items() for s in tr["categories"]["pg-primitive"].values()
                for m in s["methods"]}

    return counts(a) == counts(b)


# --- the command ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("args, message", [
    (["--task", "sweeping", "--methods", "TOG-Net,Dex-Net"], "unknown method 'Dex-Net'"),
    (["--task", "cooking"], "unknown task"),
    (["--task", "sweeping", "--category", "pg-simple"], "unknown category"),
    (["--task", "sweeping", "--grasp-model", "{tmp}/missing.pt"], "checkpoint not found"),
    (["--task", "sweeping", "--out", "{tmp}/a-file"], "exists and is not a folder"),
])
def test_the_command_names_bad_input_in_one_line(tmp_path, models, args, message):
    (tmp_path / "a-file").write_text("x")
    base = ["evaluate", "--out", str(tmp_path / "out"), "--episodes", "1",
            "--grasp-model", str(models["grasping"]), "--task-model", f"sweeping={models['sweeping']}",
            "--task-model", f"sweeping_search={models['sweeping_search']}"]
    result = CliRunner().invoke(app, base + [a.replace("{tmp}", str(tmp_path)) for a in args])
    assert result.exit_code == 2, result.output
    assert message in result.output and "Traceback" not in result.output


def test_the_report_says_when_a_resumed_run_only_re_rendered_it():
    from tognet.evaluate.report import _settings_lines

    results = {"settings": {"tasks": ["pulling"], "episodes": 3, "categories": ["pg-primitive"],
                            "models": {}, "config_hash": "abc"},
               "run": {"episodes_run_now": 0, "seconds_now": 0.0, "episodes_per_s_now": None, "workers": 2}}
    assert "re-rendered the report" in _settings_lines(results, None)[3]
    results["run"].update(episodes_run_now=18, seconds_now=6.0, episodes_per_s_now=3.0)
    line = _settings_lines(results, None)[3]
    assert "18 episodes in 6 s (3.00 episodes/s on 2 workers)" in line and "re-rendered" not in line

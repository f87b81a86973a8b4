"""The whole loop at toy scale: objects, grasp-only round and model, task rounds with training, resume."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

import tognet.collect
from tognet.cli import app
from tognet.collect.config import PRESETS, CollectConfig, PipelineConfig, RoundConfig, load_preset
from tognet.collect.pipeline import PipelineError, run_pipeline
from tognet.model.config import TrainConfig

TOY = PipelineConfig(
    name="toy",
    objects={"primitive": 3},
    grasp_round=RoundConfig(episodes=12, policy="nms_uniform", epochs=1),
    rounds=(RoundConfig(episodes=12, policy="nms_uniform", epochs=1),
            RoundConfig(episodes=12, policy="epsilon_greedy", epochs=1)),
    collect=CollectConfig(trials_per_scene=4, scenes_per_job=1),
    train=TrainConfig(batch_size=8, val_fraction=0.34, patience=2),
)


@pytest.fixture(scope="module")
def toy_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("pipeline") / "run"
    summary = run_pipeline(TOY, ["sweeping"], out, workers=0, progress=False, log=lambda _m: None)
    return out, summary


def test_pipeline_writes_rounds_models_and_summary(toy_run):
    out, summary = toy_run
    rows = summary["tasks"]["sweeping"]
    assert [r["collection"]["policy"] for r in rows] == ["nms_uniform", "epsilon_greedy"]
    assert all(r["collection"]["valid"] == 12 for r in rows)
    # round 2 explores with the round-1 model: CEM grasps and policy actions appear, epsilon-mixed
    sources = rows[1]["collection"]["by_source"]
    assert any(k.startswith("cem+") for k in sources) and any(k.endswith("+policy") for k in sources)
    assert rows[1]["model"]["init_from"].endswith("round1/model/best.pt")
    for k in (1, 2):
        assert (out / "sweeping" / f"round{k}" / "model" / "best.pt").is_file()
        assert (out / "sweeping" / f"round{k}" / "model" / "curves.png").is_file()
    assert (out / "grasping" / "model" / "best.pt").is_file()
    text = (out / "summary.md").read_text()
    assert "| 2 | epsilon_greedy | 12 |" in text and "grasp-only round" in text
    assert json.loads((out / "summary.json").read_text())["preset"] == "toy"


def test_pipeline_resumes_inside_a_round_and_refuses_a_rerun(toy_run, tmp_path):
    out, summary = toy_run
    with pytest.raises(PipelineError, match="pass --resume"):
        run_pipeline(TOY, ["sweeping"], out, workers=0, progress=False, log=lambda _m: None)
    with pytest.raises(PipelineError, match="another preset"):
        run_pipeline(TOY.replace(name="other"), ["sweeping"], out, workers=0, resume=True, progress=False,
                     log=lambda _m: None)
    # as if killed inside round 2: one shard and the round's summary gone, its model not finished
    r2 = out / "sweeping" / "round2"
    (r2 / "data" / "summary.json").unlink()
    (r2 / "data" / "shard-000001.npz").unlink()
    for name in ("done.json", "best.pt", "last.pt"):
        (r2 / "model" / name).unlink()
    log: list[str] = []
    with pytest.warns(UserWarning, match="missing; its job runs again"):
        again = run_pipeline(
            TOY, ["sweeping"], out, workers=0, resume=True, progress=False, log=log.append)
    assert any("2 of 3 jobs already written" in m for m in log)
    row = again["tasks"]["sweeping"][1]
    assert row["collection"]["valid"] == summary["tasks"]["sweeping"][1]["collection"]["valid"]
    assert row["collection"]["task_success"] == summary["tasks"]["sweeping"][1]["collection"]["task_success"]
    assert (r2 / "model" / "best.pt").is_file()


def test_presets_load_and_cli_errors_are_one_line(tmp_path):
    for name in ("ci", "quick", "paper"):
        preset = load_preset(name)
        assert preset.name == name and len(preset.rounds) == 3
        assert preset.rounds[0].policy == "nms_uniform" and preset.rounds[1].policy == "epsilon_greedy"
    search = load_preset("quick-search")  # the learned action search's recipe: action-conditioned task models
    assert all(search.train_for(t).arch.task_head == "action" for t in ("sweeping", "hammering", "pulling"))
    assert search.train_for("grasping").arch.task_head == "policy"
    assert [r.episodes for r in search.rounds_for("hammering")] == [24000, 16000, 16000]
    medium = load_preset("medium")  # between quick-search and paper: more objects, more rounds
    assert medium.objects == {"primitive": 300, "complex": 300}
    for t in ("sweeping", "hammering", "pulling"):
        rounds = medium.rounds_for(t)
        assert len(rounds) == 6 and rounds[0].policy == "nms_uniform"
        assert all(r.policy == "epsilon_greedy" for r in rounds[1:])
        assert medium.train_for(t).arch.task_head == "action"
    assert set(PRESETS) == {p.stem for p in (Path(tognet.collect.__file__).parent / "presets").glob("*.json")}
    paper = load_preset("paper")
    assert paper.objects == {"primitive": 9000, "complex": 9000} and paper.rounds[0].episodes == 500_000
    runner = CliRunner()
    bad = tmp_path / "typo.json"
    bad.write_text(json.dumps({"config_type": "PipelineConfig", "roundz": []}))
    out = str(tmp_path / "o")
    res = runner.invoke(app, ["pipeline", "--task", "sweeping", "--preset", str(bad), "--out", out])
    assert res.exit_code == 2 and "unknown key 'roundz'" in res.output and "Traceback" not in res.output
    res = runner.invoke(app, ["pipeline", "--task", "pouring", "--preset", "ci", "--out", out])
    assert res.exit_code == 2 and "unknown task" in res.output
    res = runner.invoke(app, ["collect", "--task", "sweeping", "--objects", str(tmp_path / "nope"),
                              "--out", str(tmp_path / "d"), "--policy", "epsilon_greedy"])
    assert res.exit_code == 2 and "--task-model" in res.output
    for first in ("epsilon_greedy", "search_candidates"):  # a round that needs a model cannot come first
        bad.write_text(json.dumps({"config_type": "PipelineConfig", "rounds": [{"policy": first}]}))
        res = runner.invoke(app, ["pipeline", "--task", "sweeping", "--preset", str(bad), "--out", out])
        assert res.exit_code == 2 and f"starts with a {first} round" in res.output
    for cmd in ("collect", "pipeline"):
        res = runner.invoke(app, [cmd, "--help"])
        assert res.exit_code == 0 and "--workers" in res.output and "--ray" in res.output


def test_export_models_copies_final_models_with_their_summaries(toy_run, tmp_path):
    from tognet.collect.pipeline import export_models
    from tognet.model.predict import TOGNetPredictor

    out, _ = toy_run
    written = export_models(out, tmp_path / "models", command="tognet pipeline --preset toy")
    assert sorted(p.name for p in written) == ["grasping.pt", "sweeping.pt"]
    info = json.loads((tmp_path / "models" / "sweeping.json").read_text())
    assert [r["round"] for r in info["rounds"]] == [1, 2] and info["command"].endswith("toy")
    assert info["rounds"][1]["history"][0]["val"]["count"] > 0
    assert (tmp_path / "models" / "sweeping.pt").read_bytes() == (
        out / "sweeping" / "round2" / "model" / "best.pt").read_bytes()
    assert TOGNetPredictor.load(tmp_path / "models" / "sweeping.pt").task == "sweeping"
    with pytest.raises(PipelineError, match="not a finished pipeline run"):
        export_models(tmp_path, tmp_path / "x")

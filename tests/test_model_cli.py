import json

from typer.testing import CliRunner

from tognet.cli import app

runner = CliRunner()


def test_help_texts():
    for args in (["train", "--help"], ["model", "info", "--help"], ["data", "synthetic", "--help"],
                 ["data", "info", "--help"]):
        result = runner.invoke(app, args)
        assert result.exit_code == 0, result.output
        assert "Usage" in result.output
    assert "--resume" in runner.invoke(app, ["train", "--help"]).output


def test_end_to_end_train_and_info(tmp_path):
    data = tmp_path / "data"
    r = runner.invoke(app, ["data", "synthetic", str(data), "--task", "hammering", "--episodes", "160",
                            "--objects", "8", "--shard-size", "64"])
    assert r.exit_code == 0, r.output
    r = runner.invoke(app, ["data", "info", str(data), "--check"])
    assert r.exit_code == 0, r.output
    assert '"episodes": 160' in r.output and "all shards readable" in r.output
    cfg = tmp_path / "train.json"
    cfg.write_text(json.dumps({"arch": {"stem_channels": 8, "block_channels": [8], "block_strides": [2],
                                        "bottleneck_channels": 4, "head_hidden": 16},
                               "batch_size": 32, "num_threads": 1, "val_fraction": 0.25,
                               "crop_storage": "float16"}))
    out = tmp_path / "out"
    r = runner.invoke(app, ["train", "--data", str(data), "--task", "hammering", "--out", str(out),
                            "--config", str(cfg), "--epochs", "2", "--no-progress"])
    assert r.exit_code == 0, r.output
    assert "done: 2 epochs" in r.output
    assert (out / "best.pt").is_file() and (out / "curves.png").is_file()
    r = runner.invoke(app, ["model", "info", str(out / "best.pt")])
    assert r.exit_code == 0, r.output
    assert "task         hammering" in r.output and "val grasp" in r.output
    test = tmp_path / "test"
    assert runner.invoke(app, ["data", "synthetic", str(test), "--task", "hammering", "--episodes", "50",
                               "--seed", "9"]).exit_code == 0
    r = runner.invoke(app, ["model", "eval", str(out / "best.pt"), "--data", str(test), "--out",
                            str(tmp_path / "eval.json")])
    assert r.exit_code == 0, r.output
    assert "reading shards" in r.output and "evaluating" in r.output  # progress bars (stderr)
    ev = json.loads((tmp_path / "eval.json").read_text())
    assert ev["count"] == 50 and ev["task_name"] == "hammering" and "auc" in ev["metrics"]["grasp"]
    assert isinstance(ev["task"], float) and ev["task"] >= 0  # the Q_T|G loss term, not the task's name
    r = runner.invoke(app, ["model", "info", "--json", str(out / "last.pt")])
    assert json.loads(r.output)["resumable"] is True
    r = runner.invoke(app, ["train", "--data", str(data), "--task", "hammering", "--out", str(out),
                            "--config", str(cfg), "--epochs", "3", "--resume", "--no-progress"])
    assert r.exit_code == 0, r.output
    assert "resuming" in r.output and "done: 3 epochs" in r.output
    # warm start from the checkpoint into a new run; a checkpoint of another task is refused
    warm = str(tmp_path / "warm")
    r = runner.invoke(app, ["train", "--data", str(data), "--task", "hammering", "--out", warm,
                            "--config", str(cfg), "--epochs", "1", "--init-from", str(out / "best.pt"),
                            "--no-progress"])
    assert r.exit_code == 0, r.output
    assert json.loads((tmp_path / "warm" / "data.json").read_text())["init_from"]["path"].endswith("best.pt")
    sweep = tmp_path / "sweep"
    assert runner.invoke(app, ["data", "synthetic", str(sweep), "--task", "sweeping", "--episodes", "40"]
                         ).exit_code == 0
    w2 = str(tmp_path / "w2")
    r = runner.invoke(app, ["train", "--data", str(sweep), "--task", "sweeping", "--out", w2,
                            "--config", str(cfg), "--epochs", "1", "--init-from", str(out / "best.pt"),
                            "--no-progress"])
    assert r.exit_code == 2 and "hammering" in r.output and "sweeping" in r.output


def test_cli_errors_are_clear(tmp_path):
    bad = tmp_path / "bad.pt"
    bad.write_bytes(b"not a checkpoint")
    r = runner.invoke(app, ["model", "info", str(bad)])
    assert r.exit_code == 2 and "bad.pt: not a readable checkpoint" in r.output
    r = runner.invoke(app, ["train", "--data", str(tmp_path / "nope"), "--task", "x", "--out",
                            str(tmp_path / "o")])
    assert r.exit_code == 2 and "dataset folder not found" in r.output
    cfg = tmp_path / "c.json"
    cfg.write_text(json.dumps({"epohcs": 3}))
    r = runner.invoke(app, ["train", "--data", str(tmp_path), "--task", "x", "--out", str(tmp_path / "o"),
                            "--config", str(cfg)])
    assert r.exit_code == 2 and "did you mean 'epochs'" in r.output


def _one_line_error(r, text):
    assert r.exit_code == 2, r.output
    lines = [ln for ln in r.output.strip().splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: ") and text in lines[0], r.output


def test_new_user_mistakes_get_one_line_errors_and_lose_nothing(tmp_path):
    data = tmp_path / "data"
    assert runner.invoke(app, ["data", "synthetic", str(data), "--task", "sweeping", "--episodes", "60",
                               "--objects", "4"]).exit_code == 0
    # wrong task, with the progress bar on: the error is the only line (no half-drawn bar around it)
    r = runner.invoke(app, ["train", "--data", str(data), "--task", "sweping", "--out", str(tmp_path / "o")])
    _one_line_error(r, "holds task 'sweeping', expected 'sweping'")
    # --out that is a file
    (tmp_path / "afile").write_text("mine")
    r = runner.invoke(app, ["train", "--data", str(data), "--task", "sweeping", "--out",
                            str(tmp_path / "afile")])
    _one_line_error(r, "is not a folder")
    assert (tmp_path / "afile").read_text() == "mine"
    # a folder holding a finished run's best.pt (last.pt deleted to save space) is not trained over
    import torch

    run = tmp_path / "run"
    run.mkdir()
    torch.save({"precious": torch.ones(2)}, run / "best.pt")
    before = (run / "best.pt").read_bytes()
    r = runner.invoke(app, ["train", "--data", str(data), "--task", "sweeping", "--out", str(run)])
    _one_line_error(r, "already holds a training run (best.pt)")
    assert (run / "best.pt").read_bytes() == before
    # a mistyped device
    r = runner.invoke(app, ["train", "--data", str(data), "--task", "sweeping", "--out", str(tmp_path / "o"),
                            "--device", "cdua"])
    _one_line_error(r, "device 'cdua': not a device")
    # --resume without a previous run
    r = runner.invoke(app, ["train", "--data", str(data), "--task", "sweeping", "--out",
                            str(tmp_path / "new"), "--resume"])
    _one_line_error(r, "nothing to resume")
    # corrupt checkpoints: one short line, not torch's advice
    (tmp_path / "bad.pt").write_bytes(b"\x80\x02garbage")
    r = runner.invoke(app, ["model", "info", str(tmp_path / "bad.pt")])
    _one_line_error(r, "not a readable checkpoint")
    (tmp_path / "trunc.pt").write_bytes(b"PK\x03\x04" + b"\x00" * 100)
    r = runner.invoke(app, ["model", "eval", str(tmp_path / "trunc.pt"), "--data", str(data)])
    _one_line_error(r, "not a readable checkpoint")
    r = runner.invoke(app, ["model", "info", str(run.parent)])
    _one_line_error(r, "is a folder, not a checkpoint file")
    # an empty folder is not a dataset
    (tmp_path / "empty").mkdir()
    _one_line_error(runner.invoke(app, ["data", "info", str(tmp_path / "empty")]), "not an episode dataset")
    r = runner.invoke(app, ["train", "--data", str(tmp_path / "empty"), "--task", "sweeping", "--out",
                            str(tmp_path / "o")])
    _one_line_error(r, "no shards found")
    assert not (tmp_path / "o").exists()

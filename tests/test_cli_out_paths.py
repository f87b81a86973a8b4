"""``--out`` naming a file where a folder is wanted (or a folder where a file is) is one line and exit
status 2, never a traceback."""

import pytest
from typer.testing import CliRunner

from tognet.cli import app


@pytest.fixture()
def paths(tmp_path):
    (tmp_path / "a-file").write_text("x")
    (tmp_path / "a-folder").mkdir()
    return tmp_path


EVAL = ["model", "eval", "{ckpt}", "--data", "{data}", "--out"]


@pytest.mark.parametrize("args, message", [
    ([*EVAL, "{tmp}/a-folder"], "is a folder; pass a file name"),
    ([*EVAL, "{tmp}/a-file/m.json"], "a-file is a file"),
    (["demo", "--out", "{tmp}/a-file", "--count", "1", "--no-tasks", "--no-evaluate"],
     "exists and is not a folder"),
    (["data", "synthetic", "{tmp}/a-file", "--episodes", "4"], "exists and is not a folder"),
    (["data", "synthetic", "{tmp}/a-file/data", "--episodes", "4"], "a-file is a file, not a folder"),
    (["collect", "--task", "sweeping", "--objects", "{tmp}", "--out", "{tmp}/a-file"], "is not a folder"),
])
def test_out_of_the_wrong_kind_is_one_line(paths, args, message):
    from tognet.data.synthetic import write_synthetic_dataset

    data = write_synthetic_dataset(paths / "data", task="sweeping", n=8, shard_size=8, n_objects=2)
    filled = [a.format(tmp=paths, data=data, ckpt=paths / "a-file") for a in args]
    result = CliRunner().invoke(app, filled)
    assert result.exit_code == 2, result.output
    assert message in result.output and "Traceback" not in result.output
    assert (paths / "a-file").read_text() == "x"  # nothing written over it

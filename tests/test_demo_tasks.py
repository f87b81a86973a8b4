"""The task part of ``tognet demo``: scripted checks, candidates on a simulated depth image, a GIF."""

import importlib.util
import re

import imageio.v3 as iio
from PIL import Image

from tognet.demo.tasks import run_task_demo
from tognet.tasks import TASK_NAMES


def test_task_demo_prints_check_rates_and_writes_pictures(tmp_path, capsys):
    written = run_task_demo(tmp_path, seeds=2, gif=True)
    out = capsys.readouterr().out
    rates = re.findall(r"^  (\w+) .* task success (\d+)/(\d+)$", out, re.MULTILINE)
    # Every registered task's two check grasps, the one that should work first: it beats the other.
    assert [task for task, _, _ in rates] == [task for task in TASK_NAMES for _ in range(2)]
    assert all(int(n) == 2 for _, _, n in rates)
    for good, bad in zip(rates[::2], rates[1::2], strict=True):
        assert int(good[1]) > int(bad[1]), (good, bad)
    png, gif, *arm = written
    assert Image.open(png).size[0] >= 512
    frames = iio.imread(gif, index=None)
    assert frames.ndim == 4 and frames.shape[0] >= 20
    assert frames[0].std() > 5  # a rendered scene, not a blank frame
    # With the robot extra, the same hammering episode on the Sawyer arm, and it hammers the peg home.
    if importlib.util.find_spec("robosuite") and importlib.util.find_spec("mink"):
        assert [p.name for p in arm] == ["hammering_sawyer.gif"]
        assert re.search(r"on the Sawyer arm: grasp_success=True task_success=True", out)
        arm_frames = iio.imread(arm[0], index=None)
        assert arm_frames.shape[0] >= 20 and arm_frames[0].std() > 5

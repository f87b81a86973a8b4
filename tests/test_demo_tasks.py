"""The task part of ``tognet demo``: scripted checks, candidates on a simulated depth image, a GIF."""

import re

import imageio.v3 as iio
from PIL import Image

from tognet.demo.tasks import run_task_demo


def test_task_demo_prints_check_rates_and_writes_pictures(tmp_path, capsys):
    written = run_task_demo(tmp_path, seeds=2, gif=True)
    out = capsys.readouterr().out
    rates = re.findall(r"task success (\d+)/(\d+)", out)
    assert len(rates) == 4 and all(int(n) == 2 for _, n in rates)
    far_end, head, short_end, long_middle = (int(k) for k, _ in rates)
    assert far_end > head and short_end > long_middle
    png, gif = written
    assert Image.open(png).size[0] >= 512
    frames = iio.imread(gif, index=None)
    assert frames.ndim == 4 and frames.shape[0] >= 20
    assert frames[0].std() > 5  # a rendered scene, not a blank frame

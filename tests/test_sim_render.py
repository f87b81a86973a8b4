"""Episode GIFs play at the simulated speed (every frame delay used to be 0: browsers then play 10 fps)."""

import os

import numpy as np
import pytest
from PIL import Image

from tognet.sim.render import GifRecorder


def _renderer_or_skip() -> None:
    import mujoco

    from tognet.sim import SimConfig  # noqa: F401  (sets MUJOCO_GL before the renderer starts)

    try:
        probe = mujoco.Renderer(mujoco.MjModel.from_xml_string("<mujoco/>"), 8, 8)
        probe.close()
    except Exception as exc:  # no EGL on this machine (`make system-deps` installs it)
        if os.environ.get("TOGNET_REQUIRE_GL") == "1":
            pytest.fail(f"TOGNET_REQUIRE_GL=1 but MuJoCo's offscreen renderer does not start: {exc}")
        pytest.skip(f"no offscreen GL backend: {exc}")


def _delays(path):
    im = Image.open(path)
    out = []
    for i in range(im.n_frames):
        im.seek(i)
        out.append(im.info["duration"])
    return np.array(out)


def test_an_episode_gif_lasts_as_long_as_the_simulated_episode(hammer_sim, tmp_path):
    _renderer_or_skip()
    hammer_sim.reset(3)
    recorder = GifRecorder(hammer_sim.model, width=96, height=72, every=1, max_fps=25)
    try:
        with hammer_sim.recording(recorder):
            assert hammer_sim.recorder is recorder
            result = hammer_sim.execute(hammer_sim.default_grasp(), np.zeros(4), seed=0)
        assert hammer_sim.recorder is None
        path = recorder.save(tmp_path / "episode.gif", fps=25, hold=0.5)
    finally:
        recorder.close()
    times = np.asarray(recorder.times)
    assert np.all(np.diff(times) >= 0.04 - 1e-9)  # max_fps: no frame closer than 1/25 s to the last
    assert times[-1] == pytest.approx(result.info["sim_time"], abs=0.05)
    delays = _delays(path)
    assert len(delays) == len(times) and np.all(delays >= 20) and np.all(delays % 10 == 0)
    shown = delays[:-1].sum() / 1000  # the last frame is held on top of its own 40 ms
    assert shown == pytest.approx(times[-1] - times[0], abs=0.011)
    assert delays[-1] == pytest.approx(40 + 500, abs=10)


def test_a_long_episode_is_thinned_to_max_frames_and_still_lasts_as_long(tmp_path):
    recorder = GifRecorder.__new__(GifRecorder)  # saving given frames needs no renderer
    recorder.frames = [np.full((8, 8, 3), (5 * i) % 250, np.uint8) for i in range(500)]
    recorder.times = list(0.02 * np.arange(1, 501))  # 10 s of simulated time at 50 frames/s
    delays = _delays(recorder.save(tmp_path / "long.gif", fps=25, max_frames=100, hold=0.0))
    assert len(delays) <= 100 and np.all(delays >= 20)
    assert delays[:-1].sum() / 1000 == pytest.approx(10.0, abs=0.15)
    twice = _delays(recorder.save(tmp_path / "fast.gif", fps=25, max_frames=100, speed=2.0, hold=0.0))
    assert twice[:-1].sum() / 1000 == pytest.approx(5.0, abs=0.15)  # speed=2: half the time

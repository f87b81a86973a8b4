"""Gymnasium environments: registration, env_checker, seeding, labels in info."""

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import tognet.envs  # noqa: F401  (registers the environments)

ENV_IDS = ["tognet/Sweeping-v0", "tognet/Hammering-v0", "tognet/Grasping-v0"]


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_env_passes_the_checker_and_is_seeded(env_id):
    env = gym.make(env_id)
    check_env(env.unwrapped, skip_render_check=True)
    obs1, info1 = env.reset(seed=4)
    obs2, info2 = env.reset(seed=4)
    np.testing.assert_array_equal(obs1["depth"], obs2["depth"])
    assert info1["object_id"] == info2["object_id"] and info1["scene_seed"] == info2["scene_seed"]
    assert obs1["depth"].shape == (424, 512) and np.all(np.isfinite(obs1["depth"]))
    action = env.action_space.sample()
    _, reward, terminated, truncated, info = env.step(action)
    assert terminated and not truncated and reward in (0.0, 1.0)
    for key in ("grasp_success", "task_success", "valid", "failure"):
        assert key in info
    env.close()


def test_env_rejects_a_wrong_action_shape():
    env = gym.make("tognet/Hammering-v0")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="shape"):
        env.unwrapped.step(np.zeros(4))
    env.close()

"""Gymnasium environments: registration, env_checker, seeding, labels in info."""

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import tognet.envs  # registers the environments

ENV_IDS = list(tognet.envs.ENV_IDS.values())


def test_every_registered_task_has_an_env():
    from tognet.tasks import TASK_NAMES

    assert set(tognet.envs.ENV_IDS) == {*TASK_NAMES, "grasping"}
    assert tognet.envs.ENV_IDS["pulling"] == "tognet/Pulling-v0"
    for env_id in ENV_IDS:
        assert env_id in gym.registry


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


@pytest.mark.parametrize("env_id", ["tognet/Hammering-v0", "tognet/Grasping-v0"])
def test_actions_are_float32_and_the_normalised_box_maps_onto_the_physical_one(env_id):
    raw = gym.make(env_id).unwrapped
    norm = gym.make(env_id, normalize_actions=True).unwrapped
    assert raw.action_space.dtype == np.float32 and norm.action_space.dtype == np.float32
    np.testing.assert_array_equal(norm.action_space.low, -1.0)
    np.testing.assert_array_equal(norm.action_space.high, 1.0)
    np.testing.assert_allclose(raw.action_space.low, raw.action_low, atol=1e-6)
    check_env(norm, skip_render_check=True)
    # The box corners and centre map onto the physical corners and centre.
    np.testing.assert_allclose(norm.physical_action(-np.ones(norm.action_space.shape)), raw.action_low)
    np.testing.assert_allclose(norm.physical_action(np.ones(norm.action_space.shape)), raw.action_high)
    centre = 0.5 * (raw.action_low + raw.action_high)
    np.testing.assert_allclose(norm.physical_action(np.zeros(norm.action_space.shape)), centre)
    # The same scene and the same physical action give the same episode through either box.
    raw.reset(seed=3)
    norm.reset(seed=3)
    physical = raw.action_low + 0.3 * (raw.action_high - raw.action_low)
    _, r1, _, _, info1 = raw.step(physical)
    _, r2, _, _, info2 = norm.step(np.full(norm.action_space.shape, -0.4))
    np.testing.assert_allclose(info2["action"], physical)
    assert (r1, info1["failure"], info1["trial_seed"]) == (r2, info2["failure"], info2["trial_seed"])
    with pytest.raises(ValueError, match="non-finite"):
        norm.step(np.full(norm.action_space.shape, np.nan))
    raw.close()
    norm.close()

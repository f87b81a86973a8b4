"""The names of what carries the hand: one MuJoCo-free list in tognet.robot.names, one unknown-robot error."""

import subprocess
import sys
import typing

import pytest

from tognet.robot.names import ARM_BASES, FLOATING, ROBOT_NAMES, check_robot_name


def test_the_names_load_without_mujoco():
    code = "import sys, tognet.robot; print(tognet.robot.ROBOT_NAMES, 'mujoco' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         timeout=120)
    assert out.stdout.strip() == "('floating', 'sawyer', 'panda') False", out.stdout + out.stderr


def test_one_check_raises_unknown_robot():
    assert ROBOT_NAMES == (FLOATING, *ARM_BASES) and all(check_robot_name(n) == n for n in ROBOT_NAMES)
    with pytest.raises(ValueError, match="unknown robot 'ur5': choose from floating, sawyer, panda"):
        check_robot_name("ur5")
    with pytest.raises(ValueError, match="unknown --robot 'ur5'"):
        check_robot_name("ur5", "--robot")


def test_the_config_and_the_arms_agree_with_the_names():
    from tognet.robot.arms import ARMS
    from tognet.sim.config import RobotConfig

    assert typing.get_args(typing.get_type_hints(RobotConfig)["name"]) == ROBOT_NAMES
    assert {n: (s.base_pos, s.base_yaw) for n, s in ARMS.items()} == {
        n: (b.position, b.yaw) for n, b in ARM_BASES.items()}

"""Real arms beside the table (optional: ``pip install 'tognet[robot]'``): the paper's Sawyer and a Panda
with their own parallel grippers, joint limits, joint speed and torque limits, inverse kinematics to
tognet's top-down grasp poses (:mod:`.ik`) and joint servos that follow a joint path (:mod:`.control`).
The floating gripper (:mod:`tognet.sim.gripper`) stays the default and does not use this package.

The names of what can carry the hand and the arms' default bases (:mod:`.names`) need nothing; the rest
is loaded on first use and needs MuJoCo; loading an arm needs robosuite's model files and IK needs mink,
and both raise :class:`RobotExtraMissing` with the install hint when the extra is missing.
"""

from typing import TYPE_CHECKING

from tognet.lazy_names import lazy_names
from tognet.robot.names import ARM_BASES, FLOATING, ROBOT_NAMES, BasePose, check_robot_name

if TYPE_CHECKING:
    from tognet.robot.arms import (
        ARM_NAMES,
        TCP_SITE,
        ArmModel,
        ArmSpec,
        HandMount,
        RobotExtraMissing,
        add_servos,
        arm_spec,
        arm_xml,
        assets_dir,
        load_arm,
        place_arm,
    )
    from tognet.robot.ik import ArmIK, IKResult, IKSettings, IKStatus, JointPath, grasp_frame, joint_path

_ARMS = ("ARM_NAMES", "TCP_SITE", "ArmModel", "ArmSpec", "HandMount", "RobotExtraMissing", "add_servos",
         "arm_spec", "arm_xml", "assets_dir", "load_arm", "place_arm")
_IK = ("ArmIK", "IKResult", "IKSettings", "IKStatus", "JointPath", "grasp_frame", "joint_path")
_WHERE = {**dict.fromkeys(_ARMS, "tognet.robot.arms"), **dict.fromkeys(_IK, "tognet.robot.ik")}

__getattr__, __dir__ = lazy_names(__name__, _WHERE)

__all__ = [
    "ARM_BASES",
    "ARM_NAMES",
    "FLOATING",
    "ROBOT_NAMES",
    "TCP_SITE",
    "ArmIK",
    "ArmModel",
    "ArmSpec",
    "BasePose",
    "HandMount",
    "IKResult",
    "IKSettings",
    "IKStatus",
    "JointPath",
    "RobotExtraMissing",
    "add_servos",
    "arm_spec",
    "arm_xml",
    "assets_dir",
    "check_robot_name",
    "grasp_frame",
    "joint_path",
    "load_arm",
    "place_arm",
]

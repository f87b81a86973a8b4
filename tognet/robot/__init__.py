"""Real arms beside the table (optional: ``pip install 'tognet[robot]'``): the paper's Sawyer and a Panda
with their own parallel grippers, joint limits, joint speed and torque limits, inverse kinematics to
tognet's top-down grasp poses (:mod:`.ik`) and joint servos that follow a joint path (:mod:`.control`).
The floating gripper (:mod:`tognet.sim.gripper`) stays the default and does not use this package.

Importing it needs only MuJoCo; loading an arm needs robosuite's model files and IK needs mink, and both
raise :class:`RobotExtraMissing` with the install hint when the extra is missing.
"""

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

__all__ = [
    "ARM_NAMES",
    "TCP_SITE",
    "ArmIK",
    "ArmModel",
    "ArmSpec",
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
    "grasp_frame",
    "joint_path",
    "load_arm",
    "place_arm",
]

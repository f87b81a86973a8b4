"""The simulator's geom groups: what each kind of geom is, for contacts, cameras and pictures."""

from __future__ import annotations

#: Geom groups: the table and static scenery, the object as seen, the gripper (hand and arm), the object's
#: collision parts, the task's props, decoration.
GROUP_STATIC, GROUP_OBJECT_VISUAL, GROUP_GRIPPER, GROUP_OBJECT_COLLISION, GROUP_PROPS, GROUP_DECOR = range(6)
#: Geom groups the depth camera's rays can hit.
CAMERA_GROUPS = (GROUP_STATIC, GROUP_OBJECT_VISUAL)

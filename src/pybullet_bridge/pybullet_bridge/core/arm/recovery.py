"""Ending a task early: rise to travel height, optionally carry a held object back and set it
down where it was picked, then go home (after a cancel); or drop the object where it is (after
a failed motion, which the safe set-down would need)."""
from __future__ import annotations

from typing import Protocol

import numpy as np

from .gripper import RELEASE_DURATION
from .planning import PickPlacePlan
from .requests import DROP_GAP
from .segments import Hold, JointMove, LinearMove, Mover, Segment


class RecoveringArm(Mover, Protocol):
    home: tuple[float, ...]

    def release(self) -> None: ...


def recovery_plan(arm: RecoveringArm, plan: PickPlacePlan, put_back: bool) -> list[Segment]:
    """Segments that end a task early: optionally put the object back, then go home."""
    yaw = plan.tool_yaw
    travel_z = plan.travel_z
    segments: list[Segment] = []

    def up_from_here() -> np.ndarray:
        position, _ = arm.kinematics.tool_pose()
        return np.array([position[0], position[1], max(position[2], travel_z)])

    segments.append(LinearMove('retreat' if not put_back else 'transport', 'rise to travel height',
                               0.5, goal=up_from_here, yaw=yaw))
    if put_back:
        back_tool = plan.grasp_tool
        segments += [
            LinearMove('transport', 'carry the object back', 1.0,
                       goal=np.array([back_tool[0], back_tool[1], travel_z]), yaw=yaw),
            LinearMove('place', 'set the object back down', 0.5,
                       goal=back_tool + np.array([0.0, 0.0, DROP_GAP]), yaw=yaw),
            Hold('release', 'open the gripper', RELEASE_DURATION, on_begin=arm.release),
            LinearMove('retreat', 'rise from the object', 0.5,
                       goal=np.array([back_tool[0], back_tool[1], travel_z]), yaw=yaw),
        ]
    segments.append(JointMove('retreat', 'return home', 1.0, goal=np.array(arm.home)))
    return segments


def drop_plan(arm: RecoveringArm) -> Segment:
    """Open the gripper where the arm is."""
    return Hold('release', 'drop the object', RELEASE_DURATION, on_begin=arm.release)

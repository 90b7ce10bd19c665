"""Planning a pick-and-place motion: key poses by inverse kinematics, then the segment list.

    approach (joint-space move above the object, then a straight descent)
    -> grasp (fingers close; the constraint ties the cube to the tool)
    -> lift -> transport (straight line at travel height) -> place (straight descent)
    -> release (constraint removed) -> retreat (straight up, then joint-space home)

Every key pose must be reachable within ``IK_TOLERANCE`` or the goal is rejected before the
arm moves.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from ..tabletop import Cube
from .gripper import GRIP_DURATION, RELEASE_DURATION
from .kinematics import top_down_orientation
from .models import ArmModel, grasp_yaw
from .requests import CLEARANCE_HEIGHT, PickPlaceRequest
from .segments import Hold, JointMove, LinearMove, Mover, Segment

#: Plan-time IK must reach every key pose this closely, or the goal is rejected (m).
IK_TOLERANCE = 0.01


class PlanningArm(Mover, Protocol):
    """The arm a plan is made for (:class:`.simulation.SimulatedArm` is one)."""

    name: str
    model: ArmModel
    base: tuple[float, float, float]
    home: tuple[float, ...]

    def grasp_offset(self) -> np.ndarray: ...

    def close_fingers(self) -> None: ...

    def grasp(self) -> None: ...

    def release(self) -> None: ...


@dataclass
class PickPlacePlan:
    """A planned task: what is moved, the key heights and poses, and the segments to run."""

    cube: Cube
    cube_body: int
    support_height: float      # m, surface the object is set down on
    travel_z: float            # m, tool height while carrying
    tool_yaw: float            # rad
    grasp_tool: np.ndarray     # tool point at the grasp
    segments: list[Segment]


def plan_pick_and_place(arm: PlanningArm, request: PickPlaceRequest,
                        spot: tuple[float, float]) -> PickPlacePlan | str:
    """Solve the key poses and build the segments; or why the arm cannot reach them."""
    cube = request.cube
    yaw_to_object = math.atan2(request.center[1] - arm.base[1], request.center[0] - arm.base[0])
    tool_yaw = grasp_yaw(request.yaw, yaw_to_object)
    down = top_down_orientation(tool_yaw)
    grasp_tool = request.center + np.array([0.0, 0.0, request.grasp_height])
    place_tool = np.array([spot[0], spot[1], request.place_center_z + request.grasp_height])
    travel_z = max(grasp_tool[2], place_tool[2]) + CLEARANCE_HEIGHT
    above_pick = np.array([grasp_tool[0], grasp_tool[1], travel_z])
    above_place = np.array([place_tool[0], place_tool[1], travel_z])
    kin = arm.kinematics
    q_grasp, grasp_error = kin.solve_ik(grasp_tool, down, start=arm.home)
    _, place_error = kin.solve_ik(place_tool, down, start=arm.home)
    q_above_pick, above_pick_error = kin.solve_ik(above_pick, down, start=q_grasp, rest=q_grasp)
    _, above_place_error = kin.solve_ik(above_place, down, start=q_above_pick, rest=q_above_pick)
    for what, error in (('grasp pose', grasp_error), ('place pose', place_error),
                        ('travel pose above the object', above_pick_error),
                        ('travel pose above the place spot', above_place_error)):
        if error > IK_TOLERANCE:
            return (f"the {arm.model.name} of arm '{arm.name}' cannot reach the {what} of "
                    f"'{cube.name}' (inverse kinematics error {error * 100:.1f} cm); out of reach")

    def place_target() -> np.ndarray:
        # Put the object's centre (not the tool) over the chosen pixel.
        return np.array([spot[0], spot[1], request.place_center_z]) - arm.grasp_offset()

    def above_place_target() -> np.ndarray:
        return np.array([*place_target()[:2], travel_z])

    home = np.array(arm.home)
    line = arm.linear_move_duration
    segments: list[Segment] = [
        JointMove('approach', 'move above the object', arm.joint_move_duration(home, q_above_pick),
                  goal=q_above_pick),
        LinearMove('approach', 'descend to the grasp pose', line(above_pick, grasp_tool), goal=grasp_tool,
                   yaw=tool_yaw),
        Hold('grasp', 'close the gripper', GRIP_DURATION, on_begin=arm.close_fingers, on_end=arm.grasp),
        LinearMove('lift', 'lift the object', line(grasp_tool, above_pick), goal=above_pick, yaw=tool_yaw),
        LinearMove('transport', 'carry the object over the place spot', line(above_pick, above_place),
                   goal=above_place_target, yaw=tool_yaw),
        LinearMove('place', 'lower the object', line(above_place, place_tool), goal=place_target,
                   yaw=tool_yaw),
        Hold('release', 'open the gripper', RELEASE_DURATION, on_begin=arm.release),
        LinearMove('retreat', 'rise from the object', line(place_tool, above_place), goal=above_place,
                   yaw=tool_yaw),
        JointMove('retreat', 'return home', arm.joint_move_duration(q_above_pick, home), goal=home),
    ]
    return PickPlacePlan(cube=cube, cube_body=cube.body_ids[0], support_height=request.support_height,
                         travel_z=travel_z, tool_yaw=tool_yaw, grasp_tool=grasp_tool, segments=segments)

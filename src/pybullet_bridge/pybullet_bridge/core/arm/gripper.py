"""The gripper: finger motors, the fixed constraint that holds a grasped cube, collision filters.

The grasp itself is a fixed constraint between the tool link and the cube, created only when
the tool is within ``GRASP_TOLERANCE`` of the grasp pose; fingers only show the motion. A
slipping grasp (the simulated execution failure) neither squeezes nor creates the constraint,
so the cube stays where it was.
"""
from __future__ import annotations

from collections.abc import Iterable

import numpy as np
import pybullet as p

from .kinematics import ArmKinematics
from .state_machine import MotionFailure

#: The tool must be this close to the grasp pose for the constraint to be created (m).
GRASP_TOLERANCE = 0.01
#: Extra finger opening on each side of the cube when approaching it (m).
FINGER_APPROACH_GAP = 0.012
#: Gap between each closed finger and the cube (m): the constraint, not friction, holds it.
FINGER_CLOSED_GAP = 0.002
GRIP_DURATION = 0.4      # s for the fingers to close
RELEASE_DURATION = 0.4   # s for the fingers to open and the object to settle


class Gripper:
    """The fingers and grasp constraint of one loaded arm."""

    def __init__(self, kinematics: ArmKinematics):
        self.kinematics = kinematics
        self.constraint: int | None = None
        #: Where the held object's centre sits relative to the tool point (world axes).
        self.grasp_offset = np.zeros(3)

    @property
    def holding(self) -> bool:
        return self.constraint is not None

    def set_fingers(self, opening: float) -> None:
        kin = self.kinematics
        if not kin.finger_indices:
            return
        model = kin.model
        opening = min(max(opening, 0.0), model.finger_max_opening)
        p.setJointMotorControlArray(kin.body, kin.finger_indices, p.POSITION_CONTROL,
                                    targetPositions=[opening] * len(kin.finger_indices),
                                    forces=[model.finger_force] * len(kin.finger_indices),
                                    physicsClientId=kin.client)

    def open_around(self, edge: float) -> None:
        """Fingers clear of a cube of side ``edge``."""
        self.set_fingers(edge / 2.0 + FINGER_APPROACH_GAP)

    def close_on(self, edge: float, slipped: bool) -> None:
        # A slipping grasp does not squeeze: the fingers stay clear of the cube.
        gap = FINGER_APPROACH_GAP if slipped else FINGER_CLOSED_GAP
        self.set_fingers(edge / 2.0 + gap)

    def ignore_cubes(self, cube_bodies: Iterable[int]) -> None:
        # pybullet_data's Panda finger collision hulls are ~3.5 cm thick, far thicker than the
        # real fingertips, and would knock over cubes 1 cm away that real fingers clear. The
        # grasp is the fixed constraint anyway, so fingers only show the motion to cubes.
        kin = self.kinematics
        for body in cube_bodies:
            for finger in kin.finger_indices:
                p.setCollisionFilterPair(kin.body, body, finger, -1, 0, physicsClientId=kin.client)

    def grasp(self, cube_body: int, grasp_tool: np.ndarray, slipped: bool) -> None:
        """Tie the cube to the tool where it is now; MotionFailure if the tool missed the grasp pose."""
        kin = self.kinematics
        tool, _ = kin.tool_pose()
        error = float(np.linalg.norm(tool - grasp_tool))
        if error > GRASP_TOLERANCE:
            raise MotionFailure(f'the tool is {error * 100:.1f} cm from the grasp pose '
                                f'(tolerance {GRASP_TOLERANCE * 100:.0f} cm); no grasp')
        if slipped:
            return
        client = kin.client
        link = p.getLinkState(kin.body, kin.tool_index, computeForwardKinematics=True, physicsClientId=client)
        cube_position, cube_orientation = p.getBasePositionAndOrientation(cube_body, physicsClientId=client)
        inverse = p.invertTransform(link[4], link[5])
        relative_position, relative_orientation = p.multiplyTransforms(
            inverse[0], inverse[1], cube_position, cube_orientation)
        self.constraint = p.createConstraint(
            kin.body, kin.tool_index, cube_body, -1, p.JOINT_FIXED, [0.0, 0.0, 0.0],
            parentFramePosition=relative_position, childFramePosition=[0.0, 0.0, 0.0],
            parentFrameOrientation=relative_orientation, physicsClientId=client)
        p.changeConstraint(self.constraint, maxForce=200.0, physicsClientId=client)
        self._set_held_collisions(cube_body, False)
        # Place the object's centre, not the tool: remember where it sits relative to the tool.
        self.grasp_offset = np.array(cube_position) - tool

    def release(self, cube_body: int, edge: float) -> None:
        """Drop the constraint (if any) and open the fingers clear of the cube."""
        if self.constraint is not None:
            p.removeConstraint(self.constraint, physicsClientId=self.kinematics.client)
            self.constraint = None
            self._set_held_collisions(cube_body, True)
        self.open_around(edge)

    def _set_held_collisions(self, cube_body: int, enabled: bool) -> None:
        kin = self.kinematics
        for link in range(-1, p.getNumJoints(kin.body, physicsClientId=kin.client)):
            p.setCollisionFilterPair(kin.body, cube_body, link, -1, int(enabled), physicsClientId=kin.client)

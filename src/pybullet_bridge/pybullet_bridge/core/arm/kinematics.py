"""An arm model loaded in pybullet: joint bookkeeping, tool pose and inverse kinematics."""
from __future__ import annotations

import math
import os

import numpy as np
import pybullet as p
import pybullet_data

from .models import ArmModel


def model_path(model: ArmModel) -> str:
    return os.path.join(pybullet_data.getDataPath(), model.urdf)


def top_down_orientation(yaw: float) -> tuple[float, float, float, float]:
    """xyzw quaternion of a tool frame pointing straight down, turned by ``yaw`` about world z.

    For the Panda the fingers then close along the world direction yaw - pi/2.
    """
    return tuple(p.getQuaternionFromEuler([math.pi, 0.0, yaw]))  # type: ignore[return-value]


class ArmKinematics:
    """Joint bookkeeping, tool pose and inverse kinematics of one loaded arm body."""

    def __init__(self, model: ArmModel, body: int, client: int):
        self.model = model
        self.body = body
        self.client = client
        names: dict[str, int] = {}
        link_of: dict[str, int] = {}
        self.movable: list[int] = []     # every non-fixed joint, in pybullet's IK order
        self.movable_names: list[str] = []
        for index in range(p.getNumJoints(body, physicsClientId=client)):
            info = p.getJointInfo(body, index, physicsClientId=client)
            joint_name, link_name = info[1].decode(), info[12].decode()
            names[joint_name] = index
            link_of[link_name] = index
            if info[2] != p.JOINT_FIXED:
                self.movable.append(index)
                self.movable_names.append(joint_name)
        missing = [j for j in model.arm_joints + model.finger_joints if j not in names]
        if missing or model.tool_link not in link_of:
            raise RuntimeError(f'{model.urdf} lacks joints {missing} or link {model.tool_link}')
        self.arm_indices = [names[j] for j in model.arm_joints]
        self.finger_indices = [names[j] for j in model.finger_joints]
        self.tool_index = link_of[model.tool_link]
        # Position of each arm joint within the IK solution vector.
        self._ik_slots = [self.movable.index(i) for i in self.arm_indices]
        self._ik_finger_slots = [self.movable.index(i) for i in self.finger_indices]
        lower, upper = [], []
        for index in self.movable:
            info = p.getJointInfo(body, index, physicsClientId=client)
            lower.append(info[8])
            upper.append(info[9])
        self._lower, self._upper = lower, upper
        self._ranges = [max(u - lo, 1e-3) for lo, u in zip(lower, upper)]

    # -- state ------------------------------------------------------------------

    def arm_positions(self) -> np.ndarray:
        states = p.getJointStates(self.body, self.arm_indices, physicsClientId=self.client)
        return np.array([s[0] for s in states])

    def movable_states(self) -> tuple[list[float], list[float], list[float]]:
        """(positions, velocities, applied efforts) of every movable joint."""
        states = p.getJointStates(self.body, self.movable, physicsClientId=self.client)
        return [s[0] for s in states], [s[1] for s in states], [s[3] for s in states]

    def reset_arm(self, positions) -> None:
        for index, value in zip(self.arm_indices, positions):
            p.resetJointState(self.body, index, float(value), 0.0, physicsClientId=self.client)

    def tool_pose(self) -> tuple[np.ndarray, tuple[float, float, float, float]]:
        """World position of the tool point and orientation (xyzw) of the tool link."""
        state = p.getLinkState(self.body, self.tool_index, computeForwardKinematics=True,
                               physicsClientId=self.client)
        position, orientation = np.array(state[4]), state[5]
        if self.model.tool_offset:
            rotation = np.array(p.getMatrixFromQuaternion(orientation)).reshape(3, 3)
            position = position + rotation[:, 2] * self.model.tool_offset
        return position, orientation

    # -- inverse kinematics ---------------------------------------------------------

    def _link_target(self, tool_position, orientation) -> list[float]:
        target = np.asarray(tool_position, dtype=float)
        if self.model.tool_offset:
            rotation = np.array(p.getMatrixFromQuaternion(orientation)).reshape(3, 3)
            target = target - rotation[:, 2] * self.model.tool_offset
        return target.tolist()

    def ik_step(self, tool_position, orientation, rest=None) -> np.ndarray:
        """Arm joint positions that move the tool toward the pose, from the current state.

        One call of pybullet's damped-least-squares IK; the null space pulls toward
        ``rest`` (arm joints; default: the current positions, so successive calls along
        a path stay on one branch).
        """
        current, _, _ = self.movable_states()
        rest_all = list(current)
        if rest is not None:
            for slot, value in zip(self._ik_slots, rest):
                rest_all[slot] = float(value)
        solution = p.calculateInverseKinematics(
            self.body, self.tool_index, self._link_target(tool_position, orientation), orientation,
            lowerLimits=self._lower, upperLimits=self._upper, jointRanges=self._ranges,
            restPoses=rest_all, maxNumIterations=50, residualThreshold=1e-5,
            physicsClientId=self.client)
        q = np.array([solution[slot] for slot in self._ik_slots])
        limits = np.array(self.model.joint_limits)
        return np.clip(q, limits[:, 0], limits[:, 1])

    def solve_ik(self, tool_position, orientation, start=None, rest=None,
                 iterations: int = 25) -> tuple[np.ndarray, float]:
        """Converged IK: (arm joint positions, remaining tool error in m).

        Iterates pybullet's IK, setting the arm's joints between calls, from ``start``
        (default: the current positions) and, if that stays off by more than 1 mm, also
        from the ``ready`` pose; the better solution wins. The arm is then put back
        exactly as it was (positions and velocities), so this may run on a live
        simulation between two physics steps.
        """
        target = np.asarray(tool_position, dtype=float)
        rest = self.model.ready if rest is None else rest
        saved = p.getJointStates(self.body, self.movable, physicsClientId=self.client)
        best_q, best_error = None, math.inf
        try:
            starts = [self.arm_positions() if start is None else np.asarray(start, dtype=float),
                      np.asarray(self.model.ready, dtype=float)]
            for first in starts:
                self.reset_arm(first)
                for _ in range(iterations):
                    q = self.ik_step(target, orientation, rest=rest)
                    self.reset_arm(q)
                    error = float(np.linalg.norm(self.tool_pose()[0] - target))
                    if error < best_error:
                        best_q, best_error = q, error
                    if error < 5e-4:
                        break
                if best_error < 1e-3:
                    break
        finally:
            for index, state in zip(self.movable, saved):
                p.resetJointState(self.body, index, state[0], state[1], physicsClientId=self.client)
        return best_q, best_error

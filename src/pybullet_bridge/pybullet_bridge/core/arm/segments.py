"""The steps of an arm's motion plan: joint-space moves, straight tool moves, holds.

Straight-line segments follow a smooth (cubic) time law capped by ``max_tool_speed``;
every physics step the tool target on the line goes through pybullet's
``calculateInverseKinematics`` (top-down tool orientation) and the joints follow with
position motors. A segment reports when it has converged and, if it has not, how far off it is.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Protocol

import numpy as np

from .kinematics import ArmKinematics, top_down_orientation
from .timing import cubic

#: A straight-line segment has converged when the tool is this close to its end (m).
POSITION_TOLERANCE = 0.005
#: A joint-space segment has converged when every joint is this close to its goal (rad).
JOINT_TOLERANCE = 0.02


class Mover(Protocol):
    """The arm a segment moves (:class:`.simulation.SimulatedArm` is one)."""

    kinematics: ArmKinematics

    def command_joints(self, positions: np.ndarray, velocities: np.ndarray | None = None) -> None: ...

    def joint_move_duration(self, start: np.ndarray, goal: np.ndarray) -> float: ...

    def linear_move_duration(self, start: np.ndarray, goal: np.ndarray) -> float: ...


@dataclass
class Segment:
    """One step of the motion plan. Subclasses fill in begin/command/converged."""

    phase: str
    step: str                 # what it does, for messages
    estimate: float           # planned duration for progress (s)
    duration: float = 0.0     # actual duration, fixed at begin (s)
    start_time: float = 0.0

    def begin(self, arm: Mover, sim_time: float) -> None:
        self.start_time = sim_time
        self.duration = self.estimate

    def command(self, arm: Mover, sim_time: float) -> None:
        """Set the motor targets for this step."""

    def converged(self, arm: Mover) -> bool:
        return True

    def error_text(self, arm: Mover) -> str:
        return ''

    def end(self, arm: Mover) -> None:
        """Called once when the segment is done (before the next begins)."""


@dataclass
class JointMove(Segment):
    goal: Callable[[], np.ndarray] | np.ndarray | None = None
    _start: np.ndarray | None = None
    _goal: np.ndarray | None = None

    def begin(self, arm: Mover, sim_time: float) -> None:
        self.start_time = sim_time
        self._start = arm.kinematics.arm_positions()
        self._goal = np.asarray(self.goal() if callable(self.goal) else self.goal, dtype=float)
        self.duration = arm.joint_move_duration(self._start, self._goal)

    def command(self, arm: Mover, sim_time: float) -> None:
        s, ds = cubic((sim_time - self.start_time) / self.duration)
        delta = self._goal - self._start
        arm.command_joints(self._start + s * delta, ds / self.duration * delta)

    def converged(self, arm: Mover) -> bool:
        return float(np.max(np.abs(arm.kinematics.arm_positions() - self._goal))) < JOINT_TOLERANCE

    def error_text(self, arm: Mover) -> str:
        error = float(np.max(np.abs(arm.kinematics.arm_positions() - self._goal)))
        return f'a joint is {error:.3f} rad from its goal'


@dataclass
class LinearMove(Segment):
    goal: Callable[[], np.ndarray] | np.ndarray | None = None
    yaw: float = 0.0
    _start: np.ndarray | None = None
    _goal: np.ndarray | None = None

    def begin(self, arm: Mover, sim_time: float) -> None:
        self.start_time = sim_time
        self._start, _ = arm.kinematics.tool_pose()
        self._goal = np.asarray(self.goal() if callable(self.goal) else self.goal, dtype=float)
        self.duration = arm.linear_move_duration(self._start, self._goal)

    def command(self, arm: Mover, sim_time: float) -> None:
        s, _ = cubic((sim_time - self.start_time) / self.duration)
        target = self._start + s * (self._goal - self._start)
        arm.command_joints(arm.kinematics.ik_step(target, top_down_orientation(self.yaw)))

    def tool_error(self, arm: Mover) -> float:
        position, _ = arm.kinematics.tool_pose()
        return float(np.linalg.norm(position - self._goal))

    def converged(self, arm: Mover) -> bool:
        return self.tool_error(arm) < POSITION_TOLERANCE

    def error_text(self, arm: Mover) -> str:
        return f'the tool is {self.tool_error(arm) * 100:.1f} cm from its target'


@dataclass
class Hold(Segment):
    """Keep the arm still for a while; run ``on_begin`` / ``on_end`` around it."""

    on_begin: Callable[[], None] | None = None
    on_end: Callable[[], None] | None = None
    _hold: np.ndarray | None = None

    def begin(self, arm: Mover, sim_time: float) -> None:
        super().begin(arm, sim_time)
        self._hold = arm.kinematics.arm_positions()
        if self.on_begin is not None:
            self.on_begin()

    def command(self, arm: Mover, sim_time: float) -> None:
        arm.command_joints(self._hold)

    def end(self, arm: Mover) -> None:
        if self.on_end is not None:
            self.on_end()

"""What a set-up coalition does while it executes, for one robot (no ROS): streaming, the motor
schemas and the values they run on.

* Streaming: every stream period a committed helper evaluates each answer it serves a coalition
  member on its current readings and incoming streams (:func:`~.information_values.evaluate`)
  and hands the value to the channel as an INFORMATION message (loss-tolerant: no ACK, the latest
  value wins; stale after ``stream_timeout``, :class:`~.transport.information_stream.InformationStream`).
* Values: the leader instantiates its task's required information from its own readings, the
  streams and the a-priori values (``goal_position`` for F_G(goal)), e.g. F_G(local) = helper's
  F_G composed with the helper's F_R(local, helper). For a request the robot answered itself
  (footnote 10) its own cheapest answer that can be computed now is used.
* Motor schemas (:mod:`.motor_schema`): ``navigate`` goes to the goal (heading from the GPS, or
  estimated from its motion when a teammate's fiducial localises it); ``push_box_cooperatively``
  pushes the box to the goal and waits while the teammate's streamed bumper is not pressed. A
  committed helper runs ``maintain_relative_position`` on its fiducial view of the leader (a
  pushing teammate also creeps into contact and keeps pressing).

Fiducial values carry the seen entity's relative orientation, so inverting F_R and composing
through a robot localised by a fiducial are computed on values; the heading estimator only
serves values that still lack a ``yaw``.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

from .agent import FeasibleCoalition, SchemaAgent
from .information import Entity, InformationInstance
from .information_values import ValueUnavailable, evaluate
from .motor_schema import STOP, BoxPush, GoToGoal, HeadingEstimator, MaintainRelativePosition, Velocity
from .settings import AgentSettings
from .transport.information_stream import InformationStream


@dataclass(frozen=True)
class MotorStep:
    """One motor-schema evaluation: the command, and the phase with its human-readable progress."""

    command: Velocity
    phase: str
    progress: str
    #: the distance the phase is measured by (navigate: robot to goal; push: box to goal), m
    goal_distance: float


class CoalitionRunner:
    """One robot's execution of the coalition it is part of (module docstring)."""

    def __init__(self, agent: SchemaAgent, settings: AgentSettings):
        self.agent = agent
        self.robot = agent.robot
        goal = settings['goal_position']
        self.priors = {InformationInstance('F_G', (Entity('goal', robot=False),)): {'x': float(goal[0]),
                                                                                     'y': float(goal[1])},
                       InformationInstance('F_M'): {}}
        self.stream = InformationStream(settings['stream_timeout'])
        # The ranges are checked by the settings, so the motor schemas' own checks cannot fail.
        self.navigate = GoToGoal(max_speed=settings['max_speed'], tolerance=settings['goal_tolerance'])
        self.push = BoxPush(standoff=settings['box_standoff'], lateral_offset=settings['push_offset'],
                            tolerance=settings['goal_tolerance'])
        self.team_motor_schema = settings.team_motor_schema
        self.heading = HeadingEstimator()
        self.follow: MaintainRelativePosition | None = None
        self.tick_period = settings['tick_period']

    # --- dynamic settings -----------------------------------------------------------------------
    def set_max_speed(self, value: float) -> None:
        self.navigate.max_speed = value
        if self.follow is not None:
            self.follow.max_speed = value

    def set_goal_tolerance(self, value: float) -> None:
        self.navigate.tolerance = self.push.tolerance = value

    # --- values ---------------------------------------------------------------------------------
    def reading(self, instance: InformationInstance, now: float) -> Mapping[str, float] | None:
        return self.agent.sensing.value(instance, now)

    def streamed(self, provider: str, instance: InformationInstance, now: float,
                 visiting: frozenset = frozenset()) -> Mapping[str, float] | None:
        """The current value of a CS leaf: a teammate's stream, or for a request this robot
        answered itself (footnote 10) its own cheapest answer that can be computed now
        (``visiting``: the self-answers being computed, so an answer never feeds itself)."""
        if provider != self.robot:
            return self.stream.value(provider, instance, now)
        if instance in visiting:
            return None
        inner = visiting | {instance}
        for lcs in self.agent.own_answers(instance):
            try:
                return evaluate(lcs, lambda i: self.reading(i, now),
                                lambda p, i: self.streamed(p, i, now, inner), self.priors,
                                self._headings())[instance]
            except ValueUnavailable:
                continue
        return None

    def _headings(self) -> dict[str, float]:
        return {} if self.heading.heading is None else {self.robot: self.heading.heading}

    def served_values(self, members: tuple[str, ...], now: float) -> list[tuple[str, InformationInstance, dict]]:
        """(requester, answer, value) of every answer this robot serves the other ``members`` that
        can be computed now (what it streams; one that cannot, e.g. the leader out of view, is
        left out: the leader sees it stale)."""
        others = [robot for robot in members if robot != self.robot]
        values = []
        for requester, answer, lcs in self.agent.served_answers(others):
            try:
                value = evaluate(lcs, lambda i: self.reading(i, now),
                                 lambda provider, i: self.streamed(provider, i, now), self.priors)[answer]
            except ValueUnavailable:
                continue
            values.append((requester, answer, value))
        return values

    # --- motor schemas --------------------------------------------------------------------------
    def leader_step(self, chosen: FeasibleCoalition, now: float) -> MotorStep:
        """The task's motor schema on the chosen coalition's values (ValueUnavailable while an
        input cannot be computed)."""
        values = evaluate(chosen.lcs, lambda i: self.reading(i, now),
                          lambda p, i: self.streamed(p, i, now), self.priors, self._headings())
        by_label: dict[tuple[str, str], dict] = {}
        for instance, value in values.items():
            by_label[(instance.label, str(instance.referents[0]) if instance.referents else '')] = value
        me = by_label[('F_G', self.robot)]
        if 'yaw' in me:
            self.heading.measured(me['yaw'])
        heading = self.heading.fix(me['x'], me['y']) if 'yaw' not in me else self.heading.heading
        goal = by_label[('F_G', 'goal')]
        if self.agent.task.motor_schema == 'navigate':  # type: ignore[union-attr]
            distance = self.navigate.distance((me['x'], me['y']), (goal['x'], goal['y']))
            command = self.navigate.command((me['x'], me['y']), heading, (goal['x'], goal['y']))
            step = MotorStep(command, 'done' if command == STOP and distance <= self.navigate.tolerance else 'navigate',
                             f'distance to goal {distance:.2f} m', distance)
        else:
            box = by_label[('F_G', 'box')]
            pressed = by_label[('F_B', self.robot)]['pressed'] > 0.5
            teammates = [v['pressed'] > 0.5 for (label, who), v in by_label.items()
                         if label == 'F_B' and who != self.robot]
            command, state = self.push.command((me['x'], me['y']), heading, (box['x'], box['y']),
                                               (goal['x'], goal['y']), pressed, all(teammates) if teammates else None)
            step = MotorStep(command, state.phase, f'box {state.box_to_goal:.2f} m from the goal', state.box_to_goal)
        self.heading.commanded(command, self.tick_period)
        return step

    def helper_step(self, leader: str, now: float) -> tuple[Velocity | None, str]:
        """A committed helper's MS maintain_relative_position: keep the leader where it was first
        seen. (command or None before the leader was ever seen, a log line when it is first seen)."""
        seen = None
        note = ''
        if 'fiducial' in self.agent.sensing.sensors:
            seen = self.reading(InformationInstance('F_R', (Entity(leader, robot=True),
                                                            Entity(self.robot, robot=True))), now)
        if seen is not None and self.follow is None:
            self.follow = MaintainRelativePosition((seen['x'], seen['y']), max_speed=self.navigate.max_speed)
            note = f'{self.robot}: keeping {leader} at ({seen["x"]:.2f}, {seen["y"]:.2f}) m'
        pressed = None
        if self.team_motor_schema == 'push_box_cooperatively' and 'bumper' in self.agent.sensing.sensors:
            bumper = self.reading(InformationInstance('F_B', (Entity(self.robot, robot=True),)), now)
            pressed = None if bumper is None else bumper['pressed'] > 0.5
        if self.follow is None:
            return None, note
        return self.follow.command(None if seen is None else (seen['x'], seen['y']), pressed), note


__all__ = ['CoalitionRunner', 'MotorStep']

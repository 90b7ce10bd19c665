"""The central computer's behaviour (Algorithm 1) as a pure class: negotiate, watch, renegotiate, abort.

The role_engine node feeds a :class:`RoleEngine` with what it sees and hears and publishes what
it decides:

* :meth:`RoleEngine.tick` (every engine period) with the current :class:`CameraView` (robot
  positions tracked on one camera frame, and the environment built from that frame) or None
  when no usable frame is there. In phase NEGOTIATE it negotiates, evaluates and assigns the
  formation's roles (:func:`.central.plan_roles`) among the robots not excluded; in phase WATCH
  it feeds the tracked positions to the problem watch (:mod:`.problems`) and, when a robot of the
  round is silent, stuck or off its role, excludes it and renegotiates among the others.
* :meth:`RoleEngine.heard` -- a player's process role from the shared channel (its heartbeat),
  after :meth:`RoleEngine.accepts` said it belongs to the round; ``arrived`` reports count toward
  the formation's completion.
* :meth:`RoleEngine.announced` -- a player without a role announced itself: a robot excluded as
  silent is back (a restarted player) and is re-included at the next negotiation.

Effects through an :class:`EnginePort`: a :class:`RoundOutcome` to publish (assignment, initial
process roles and the map they were negotiated on), log lines, and "finished" (the formation is
complete, or the task infeasible or aborted).

Renegotiation policy (where the paper is silent, ours): a renegotiation with fewer usable robots
than ``min_robots`` aborts the task; so does a renegotiation that finds no feasible assignment
(the first negotiation then says ``infeasible``). An excluded robot stays excluded for the rest
of the task (the camera sees it as an obstacle), except a robot excluded as *silent* whose player
announces itself again (it was restarted, or its link is back): it is re-included and the robots
renegotiate, at most :data:`MAX_REJOINS` times per robot, so a player that keeps falling silent
cannot make the team renegotiate forever. A stuck or off-role robot stays out: its player being
alive says nothing about the robot.
"""
from __future__ import annotations

import time
from collections import Counter
from dataclasses import dataclass
from enum import Enum
from typing import Callable, Mapping, Protocol, Sequence

import numpy as np

from .central import plan_roles
from .conflict import SharedRole
from .environment import Environment
from .errors import RoleEngineError
from .formation_task import FormationTask, TeamMember, TypedGPEvaluator
from .negotiation import Agent
from .problems import ProblemWatch
from .tuning import EngineTuning


#: Re-inclusions of one robot excluded as silent (module docstring).
MAX_REJOINS = 3


class EnginePhase(Enum):
    NEGOTIATE = 'negotiate'    # a (re)negotiation is due at the next usable camera frame
    WATCH = 'watch'            # roles assigned: watching the robots for problems
    DONE = 'done'              # infeasible or aborted: nothing more to decide


@dataclass(frozen=True)
class CameraView:
    """One camera frame as the engine uses it: ``time`` (s, the frame's stamp), every team robot's
    tracked position (None: not found), and ``environment(robots)``: the frame's environment with
    those robots cut out of the obstacles."""

    time: float
    positions: Mapping[str, tuple[float, float] | None]
    environment: Callable[[Sequence[str]], Environment]


@dataclass(frozen=True)
class AssignedRole:
    robot: str
    role_id: str
    goal: tuple[float, float]
    role: SharedRole               # the initial process role (start_time = the round's start)


@dataclass(frozen=True)
class RoundOutcome:
    """A negotiation round's result: ``status`` is assigned, infeasible or aborted; ``message`` says
    why the round was negotiated (and, when not assigned, why it failed). ``environment`` is the map
    the roles were negotiated on (None when nothing was assigned)."""

    round: int
    status: str
    message: str
    excluded: tuple[str, ...]
    roles: tuple[AssignedRole, ...] = ()
    environment: Environment | None = None


class EnginePort(Protocol):
    def publish_round(self, outcome: RoundOutcome) -> None:
        ...

    def log(self, level: str, text: str, throttle: float = 0.0) -> None:
        """``level``: info, warn or error; ``throttle`` s between repeats (0: none)."""

    def task_ended(self) -> None:
        """The task is over: formation complete, infeasible or aborted."""


class RoleEngine:
    """The central computer's decisions (module docstring)."""

    def __init__(self, task: FormationTask, team: Sequence[TeamMember], tuning: EngineTuning, port: EnginePort):
        self.task = task
        self.team = list(team)
        self.members = {m.name: m for m in self.team}
        self.tuning = tuning
        self.port = port
        self.watch = ProblemWatch(tuning.problems)
        self.phase = EnginePhase.NEGOTIATE
        self.pending_why = 'initial negotiation'
        self.round = 0
        self.active: list[str] = []          # robots of the current round
        self.excluded: list[str] = []
        self.silent: set[str] = set()        # excluded as silent: re-included when their player is back
        self.rejoins: Counter[str] = Counter()
        self.arrived: set[str] = set()

    def retune(self, tuning: EngineTuning) -> None:
        """New tuning: the next check or negotiation uses it."""
        self.tuning = tuning
        self.watch.settings = tuning.problems

    # --- the shared channel -------------------------------------------------------------------
    def accepts(self, robot: str, round_: int, version: int) -> bool:
        """Whether a process role on the channel is a player's role of the current round (version 0
        is the engine's own initial role)."""
        return round_ == self.round and version != 0 and robot in self.active

    def heard(self, robot: str, now: float, role: SharedRole, role_id: str, arrived: bool) -> None:
        self.watch.heard(robot, now, role, arrived=arrived)
        if arrived and robot not in self.arrived:
            self.arrived.add(robot)
            self.port.log('info', f'{robot} arrived at {role_id} ({len(self.arrived)}/{len(self.active)})')
            if self.arrived >= set(self.active):
                self.port.log('info', f'round {self.round}: formation complete')
                self.port.task_ended()

    def announced(self, robot: str) -> bool:
        """A robot's player announced itself without a role; True when that re-included the robot (it had
        been excluded as silent, the task goes on, and it has rejoined fewer than MAX_REJOINS times)."""
        if robot not in self.silent or self.phase is EnginePhase.DONE:
            return False
        if self.rejoins[robot] >= MAX_REJOINS:
            self.port.log('warn', f'{robot} is back but stays excluded: it rejoined {MAX_REJOINS} times already',
                          throttle=30.0)
            return False
        self.silent.discard(robot)
        self.excluded.remove(robot)
        self.rejoins[robot] += 1
        self.pending_why = f'{robot} is back'
        self.phase = EnginePhase.NEGOTIATE
        self.port.log('info', f'{robot} is back (its player announced itself): renegotiating with it')
        return True

    # --- the engine period --------------------------------------------------------------------
    def tick(self, now: float, view: CameraView | None) -> None:
        if self.phase is EnginePhase.NEGOTIATE:
            if view is not None:
                self._negotiate(now, view, self.pending_why)
        elif self.phase is EnginePhase.WATCH:
            if view is not None:
                for robot in self.active:
                    position = view.positions.get(robot)
                    if position is not None:
                        self.watch.observed(robot, view.time, position)
            problems = [p for p in self.watch.problems(now) if p.robot in self.active]
            if problems:
                why = '; '.join(str(p) for p in problems)
                self.port.log('warn', f'round {self.round}: {why}; renegotiating without them')
                self.excluded.extend(p.robot for p in problems)
                self.silent.update(p.robot for p in problems if p.kind == 'silent')
                self.phase = EnginePhase.NEGOTIATE
                self.pending_why = why
                if view is not None:
                    self._negotiate(now, view, why)

    def _negotiate(self, now: float, view: CameraView, why: str) -> None:
        robots = [m for m in self.team if m.name not in self.excluded]
        if self.round > 0 and len(robots) < self.tuning.min_robots:
            self._abort(f'{why}: {len(robots)} usable robot(s) left, the formation needs min_robots = '
                        f'{self.tuning.min_robots}')
            return
        missing = [m.name for m in robots if view.positions.get(m.name) is None]
        if missing:
            self.port.log('warn', f"not seen on the camera image: {', '.join(missing)}", throttle=5.0)
            return
        environment = view.environment([m.name for m in robots])
        agents = [Agent(m.name, m.robot_type, view.positions[m.name]) for m in robots]
        roles = self.task.roles(len(agents)) if agents else []
        self.round += 1
        began = time.perf_counter()
        plan = None
        try:
            if agents:
                plan = plan_roles(agents, roles, environment, total_time=self.task.total_time,
                                  num_intervals=self.task.states - 1, lam=self.tuning.qualification_lambda,
                                  epsilon=self.task.gp.get('epsilon', 0.1), evaluate=TypedGPEvaluator(self.task))
        except RoleEngineError as error:
            self.port.log('error', f'round {self.round}: {error}')
        if plan is None or not plan.feasible:
            # A renegotiation after a problem that finds no assignment aborts the task.
            status = 'infeasible' if self.round == 1 else 'aborted'
            message = f'{why}: ' + (plan.reason if plan is not None else 'no robot left to assign')
            self.active = []
            self.phase = EnginePhase.DONE
            self.port.log('error', f'round {self.round}: {status}: {message}')
            self.port.publish_round(RoundOutcome(self.round, status, message, tuple(self.excluded)))
            self.port.task_ended()
            return
        start_time = now + self.tuning.start_delay
        goals = {r.name: (float(r.destination[0]), float(r.destination[1])) for r in roles}
        assigned = tuple(
            AssignedRole(name, role_id, goals[role_id],
                         SharedRole(name, np.asarray(trajectory, dtype=float), float(self.task.total_time),
                                    float(self.members[name].robot_type.radius), float(start_time)))
            for name, (role_id, trajectory) in plan.process_roles.items())
        self.active = [a.robot for a in assigned]
        self.arrived = set()
        self.watch.expect({a.robot: a.role for a in assigned})
        self.phase = EnginePhase.WATCH
        self.port.log('info', f'round {self.round} ({why}): ' + ', '.join(f'{a.robot}->{a.role_id}' for a in assigned)
                      + f' (planned in {time.perf_counter() - began:.1f} s wall)')
        self.port.publish_round(RoundOutcome(self.round, 'assigned', why, tuple(self.excluded), assigned, environment))

    def _abort(self, why: str) -> None:
        """Not negotiable: an 'aborted' round naming why; nothing more is watched."""
        self.round += 1
        self.active = []
        self.phase = EnginePhase.DONE
        self.port.publish_round(RoundOutcome(self.round, 'aborted', why, tuple(self.excluded)))
        self.port.log('error', f'round {self.round}: aborted: {why}')
        self.port.task_ended()

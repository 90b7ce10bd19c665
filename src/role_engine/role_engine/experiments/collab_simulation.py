"""The core-level simulation of ``roles-collab``: the role player of the nodes (:class:`~role_engine.core.player.RolePlayer`)
driving kinematic differential-drive robots, every player re-planning from one snapshot of the channel.

Not pybullet: unicycle robots under the bridge's own velocity and acceleration limiting
(``pybullet_bridge.core.diff_drive.limit_velocity``), integrated in ``integration_substeps`` per
control step at ``control_rate``; positions are exact, as the camera tracker would report them
without its noise. Each robot's :class:`~role_engine.core.player.RolePlayer` -- the class the
role_player node runs -- gets its pose and a control step every step, and every
``replan_period`` every player re-plans from the same snapshot of the channel (all players
publish together: a synchronous stand-in for the nodes' independent timers). What the channel
carries is the method:

- **task-based** (Fig. 11A): "robots share only their last positions and compute their distance
  to find shared collision likelihood": each robot is seen as a robot at rest at its last
  position (a two-state role that never moves); no one sees where the others are going.
- **role-based** (Fig. 11B, Algorithm 4): the others' process roles as published; the conflict
  field compares time-indexed roles.

The central computer's initial process roles (negotiation, GP inference, GRA:
:func:`~role_engine.core.central.plan_roles`; one robot per goal when the goals are labeled) are
computed once and played by each method; every role starts at t = 0.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from pybullet_bridge.core.diff_drive import DiffDriveLimits, limit_velocity
from pybullet_bridge.core.scenario import load_scenario

from ..core.central import plan_roles
from ..core.conflict import SharedRole
from ..core.environment import Environment, RobotEnvironment, RobotType
from ..core.errors import RoleEngineError
from ..core.formation_task import FormationTask, TypedGPEvaluator, team_from_scenario
from ..core.negotiation import Agent, Role
from ..core.player import PublishedRole, RolePlayer, RoundAssignment
from ..core.tuning import PlayerTuning
from .collab_config import METHODS, CollabConfig, CollabScenario
from .path_measures import hermite_jerk


@dataclass
class RunRecord:
    """What one simulated run produced (all arrays sampled every control step)."""

    method: str
    times: np.ndarray
    positions: dict[str, np.ndarray]
    velocities: dict[str, np.ndarray]          # planar velocity of the body (K, 2)
    role_jerks: dict[str, np.ndarray]          # |jerk| of the role being played (K,)
    arrived_at: dict[str, float | None]
    goals: dict[str, np.ndarray] = field(default_factory=dict)
    replan_ms: list[float] = field(default_factory=list)
    replans_kept: int = 0
    conflicts_seen: int = 0


def initial_process_roles(scenario: CollabScenario, environment: Environment,
                          team: list['SimMember']) -> dict[str, np.ndarray]:
    """The central computer's initial process roles (Algorithm 1 lines 1-6), name -> (N+1, 4) states."""
    task = scenario.task
    agents = [Agent(m.name, m.robot_type, tuple(m.start[:2])) for m in team]
    settings = dict(total_time=task.total_time, num_intervals=task.states - 1, lam=task.qualification_lambda,
                    epsilon=task.gp.get('epsilon', 0.1), evaluate=TypedGPEvaluator(task))
    if scenario.goals is None:
        plans = [plan_roles(agents, task.roles(len(agents)), environment, **settings)]
    else:
        unknown = sorted(set(scenario.goals) - {m.name for m in team})
        missing = sorted({m.name for m in team} - set(scenario.goals))
        if unknown or missing:
            raise RoleEngineError(f'scenario {scenario.name}.goals: must give one goal per robot of the scenario '
                                  f'(unknown: {unknown}, missing: {missing})')
        plans = [plan_roles([agent], [Role(f'goal_{agent.name}', scenario.goals[agent.name])], environment,
                            **settings) for agent in agents]
    roles = {}
    for plan in plans:
        if not plan.feasible:
            raise RoleEngineError(f'scenario {scenario.name}: no initial process roles ({plan.reason})')
        roles.update({name: trajectory for name, (_, trajectory) in plan.process_roles.items()})
    return roles


@dataclass(frozen=True)
class SimMember:
    """A team member with its start pose and platform limits (from the bridge scenario)."""

    name: str
    robot_type: RobotType
    start: tuple[float, float, float]
    limits: DiffDriveLimits
    color: tuple[float, float, float]


def scenario_team(task: FormationTask):
    """(bridge scenario, team with start poses and limits) of a formation task."""
    scenario = load_scenario(task.scenario)
    members = {m.name: m for m in team_from_scenario(scenario, task.inflation_margin)}
    team = [SimMember(r.name, members[r.name].robot_type, tuple(float(v) for v in r.initial_pose), r.params.limits,
                      members[r.name].color) for r in scenario.sections['mobile_robots']]
    return scenario, team




def _at_rest(name: str, position, radius: float, now: float) -> SharedRole:
    """What a task-based robot shares: its last position, as a role that never moves."""
    state = [float(position[0]), float(position[1]), 0.0, 0.0]
    return SharedRole(name, np.array([state, state]), 1.0, radius, now)


class SimulatedRobot:
    """One robot of the simulation and its role player's port: the player's commands drive the
    unicycle; what it publishes goes to the simulated channel."""

    def __init__(self, member: SimMember, robot_env: RobotEnvironment, channel: dict[str, SharedRole],
                 tuning: PlayerTuning):
        self.member = member
        self.robot_env = robot_env
        self.channel = channel
        self.pose = np.array(member.start, dtype=float)       # x, y, yaw
        self.velocity = (0.0, 0.0)                            # linear, angular actually applied
        self.target = (0.0, 0.0)                              # the player's last command
        self.player = RolePlayer(member.name, tuning, self)

    # --- the player's port ----------------------------------------------------------------------
    def command(self, linear: float, angular: float) -> None:
        self.target = (linear, angular)

    def publish_role(self, published: PublishedRole) -> None:
        self.channel[published.robot] = published.role

    def round_environment(self, round_: int) -> RobotEnvironment:
        return self.robot_env

    def log(self, level: str, text: str, throttle: float = 0.0) -> None:
        pass

    # --- the simulated body ---------------------------------------------------------------------
    def drive(self, dt: float, substeps: int) -> None:
        """The player's command, limited as the bridge does, integrated over one control step."""
        h = dt / substeps
        for _ in range(substeps):
            self.velocity = limit_velocity(self.target, self.velocity, self.member.limits, h)
            v, w = self.velocity
            yaw = self.pose[2]
            if abs(w) < 1e-9:
                self.pose[0] += v * h * math.cos(yaw)
                self.pose[1] += v * h * math.sin(yaw)
            else:                                    # exact unicycle arc
                self.pose[0] += v / w * (math.sin(yaw + w * h) - math.sin(yaw))
                self.pose[1] -= v / w * (math.cos(yaw + w * h) - math.cos(yaw))
            self.pose[2] = (yaw + w * h + math.pi) % (2 * math.pi) - math.pi


def simulate(method: str, task: FormationTask, team: list[SimMember], environment: Environment,
             initial: dict[str, np.ndarray], config: CollabConfig) -> RunRecord:
    """One run of ``method`` from the initial roles (module docstring); roles start at t = 0."""
    if method not in METHODS:
        raise RoleEngineError(f"method: must be one of {', '.join(METHODS)} (got {method!r})")
    dt = 1.0 / config.control_rate
    views = {}
    for member in team:
        if member.robot_type.name not in views:
            views[member.robot_type.name] = environment.for_robot(member.robot_type)
    initial_roles = {m.name: SharedRole(m.name, initial[m.name], task.total_time, m.robot_type.radius, 0.0)
                     for m in team}
    channel = dict(initial_roles)             # the latest process role of every robot, as published
    robots = {m.name: SimulatedRobot(m, views[m.robot_type.name], channel, PlayerTuning.from_task(task, m.robot_type))
              for m in team}
    assignment = RoundAssignment(1, 'assigned', 'initial negotiation',
                                 {name: (f'role_{name}', role) for name, role in initial_roles.items()})
    for robot in robots.values():
        robot.player.on_assignment(assignment)
    record = RunRecord(method, np.zeros(0), {}, {}, {}, {}, goals={n: t[-1, :2] for n, t in initial.items()})
    times, positions, velocities, jerks = [], {n: [] for n in robots}, {n: [] for n in robots}, {n: [] for n in robots}
    limit = config.time_limit_factor * task.total_time
    replan_every = max(1, int(round(task.replan_period / dt)))
    step = 0
    while True:
        now = step * dt
        for robot in robots.values():
            robot.player.observe(now, robot.pose)
        if step > 0 and step % replan_every == 0:
            _replan_all(method, robots, channel, now, record)
        times.append(now)
        for name, robot in robots.items():
            player = robot.player
            positions[name].append(robot.pose[:2].copy())
            v = robot.velocity[0]
            velocities[name].append([v * math.cos(robot.pose[2]), v * math.sin(robot.pose[2])])
            jerks[name].append(hermite_jerk(player.role, now) if player.arrived_at is None else 0.0)
        if all(r.player.arrived_at is not None for r in robots.values()) or now >= limit:
            break
        for robot in robots.values():
            robot.player.control(now)
            robot.drive(dt, config.integration_substeps)
        step += 1
    record.times = np.array(times)
    record.positions = {n: np.array(p) for n, p in positions.items()}
    record.velocities = {n: np.array(v) for n, v in velocities.items()}
    record.role_jerks = {n: np.array(j) for n, j in jerks.items()}
    record.arrived_at = {n: r.player.arrived_at for n, r in robots.items()}
    return record


def _replan_all(method: str, robots: dict[str, SimulatedRobot], channel: dict[str, SharedRole], now: float,
                record: RunRecord) -> None:
    """Algorithm 4 lines 2-7 for every player from one snapshot of the channel."""
    if method == 'role_based':
        snapshot = dict(channel)
    else:
        snapshot = {n: _at_rest(n, r.pose[:2], r.member.robot_type.radius, now) for n, r in robots.items()}
    for robot in robots.values():
        for other, role in snapshot.items():
            robot.player.on_role(other, robot.player.round, role)
    for robot in robots.values():
        began = time.perf_counter()
        result = robot.player.replan(now)
        if result is None:
            continue                          # arrived: nothing re-planned, only the heartbeat
        record.replan_ms.append((time.perf_counter() - began) * 1e3)
        record.conflicts_seen += bool(result.conflicting)
        if result.trajectory is None:
            record.replans_kept += 1

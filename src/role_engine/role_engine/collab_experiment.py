"""Task-based vs role-based collaboration (paper Sec. V-A-3, V-A-4; ``scripts/experiment roles-collab``).

Settings: ``config/roles/collab.yaml`` (documented there). Every scenario names a formation
task file (``config/roles/formation_demo.yaml`` format: bridge scenario, GP settings, replan
period, conflict horizon) and optionally labeled goals. The central computer's initial process
roles (negotiation, GP inference, GRA: :func:`.core.central.plan_roles`; one robot per goal
when the goals are labeled) are computed once and played by each method:

- **task-based** (Fig. 11A): "robots share only their last positions and compute their distance
  to find shared collision likelihood". Each role player re-plans with
  :func:`.core.formation_task.replan_process_role`, the others given as robots at rest at their
  last positions (a two-state role that never moves); no one sees where the others are going.
- **role-based** (Fig. 11B, Algorithm 4): the others' process roles as published on the shared
  channel; the conflict field compares time-indexed roles.

Both are run in a **core-level simulation**, not in pybullet: kinematic differential-drive
robots (unicycle, the bridge's own velocity and acceleration limiting,
``pybullet_bridge.core.diff_drive.limit_velocity``) driven by the core trajectory follower at
``control_rate``; positions are exact, as the camera tracker would report them without its
noise. Every ``replan_period`` every role player that has not arrived re-plans from the same
snapshot of the channel (all players publish together: a synchronous stand-in for the nodes'
independent timers). A robot has arrived when its role is over and it is within the task's
``arrival_tolerance`` of its destination (as the role_player node decides).

Measures, per scenario and method:

- ``completed``: every robot arrived before ``time_limit_factor x total_time``.
- ``average_jerk`` (m/s^3): the paper's smoothness cost, "the average jerk (change of
  acceleration) of the trajectories", on the driven paths: |d^3 p / dt^3| by finite differences
  of the robots' planar velocities at the control rate, averaged over time until each robot
  arrived, then over robots. ``role_jerk`` is the same average on the process roles being played
  (their cubic Hermite interpolant's third derivative at each control step; switches between
  roles are not counted).
- ``min_distance`` (m): least distance between two robot centres over the run, with the pair
  and its ``sum_of_radii``; ``min_clearance`` = the least (distance - sum of radii) over pairs.
- ``collisions``: contacts between robots, counted as onsets (a pair coming closer than the
  sum of its radii; staying in contact counts once). The kinematic robots pass through each
  other, so a contact does not stop the run. ``obstacle_contacts``: the same for a robot
  disc touching a static obstacle.

Acceptance (the exit code): in every scenario the role-based run completes with no collision,
its minimum centre distance never below the pair's sum of radii, and no robot touching a static
obstacle (kinematic robots can drive through walls, e.g. squeeze past each other in the hallway;
such a "pass" is not one).
"""
from __future__ import annotations

import json
import math
import statistics
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from pybullet_bridge.core.diff_drive import DiffDriveLimits, limit_velocity
from pybullet_bridge.core.fields import Fields, check_vector, fail, join_path, read_yaml_file, require_list
from pybullet_bridge.core.scenario import load_scenario

from .core.central import plan_roles
from .core.conflict import SharedRole
from .core.controller import TrajectoryFollower
from .core.environment import Environment, RobotType, environment_from_scenario
from .core.errors import RoleEngineError
from .core.formation_task import (FormationTask, TypedGPEvaluator, load_formation_task, replan_process_role,
                                  team_from_scenario)
from .core.negotiation import Agent, Role

Log = Callable[[str], None]

CONFIG_FILE = 'roles/collab.yaml'
METHODS = ('task_based', 'role_based')
METHOD_LABEL = {'task_based': 'task-based (last positions)', 'role_based': 'role-based (process roles)'}
TOP_LEVEL_KEYS = ('control_rate', 'integration_substeps', 'time_limit_factor', 'methods', 'scenarios')


# ------------------------------------------------------------------------------------ settings
@dataclass(frozen=True)
class CollabScenario:
    name: str
    task: FormationTask
    goals: dict[str, tuple[float, float]] | None     # labeled destinations, or None: formation + GRA


@dataclass(frozen=True)
class CollabConfig:
    source: Path
    control_rate: float
    integration_substeps: int
    time_limit_factor: float
    methods: tuple[str, ...]
    scenarios: tuple[CollabScenario, ...]


def load_collab_config(path: str | Path) -> CollabConfig:
    """The validated settings file; ValueError (RoleEngineError / the bridge's field errors) naming the field."""
    path = Path(path)
    where = str(path)
    data = read_yaml_file(path, 'settings file')
    fields = Fields(data, where, allowed=TOP_LEVEL_KEYS)
    methods = require_list(fields.raw('methods', list(METHODS)), fields.path_of('methods'))
    for index, method in enumerate(methods):
        if method not in METHODS:
            raise fail(join_path(fields.path_of('methods'), index), f"must be one of {', '.join(METHODS)} "
                                                                     f'(got {method!r})')
    if not methods or len(set(methods)) != len(methods):
        raise fail(fields.path_of('methods'), 'must list each method at most once, at least one')
    entries = require_list(fields.raw('scenarios'), fields.path_of('scenarios'))
    if not entries:
        raise fail(fields.path_of('scenarios'), 'must list at least one scenario')
    scenarios = []
    for index, entry in enumerate(entries):
        at = join_path(fields.path_of('scenarios'), index)
        item = Fields(entry, at, allowed=('name', 'task', 'goals'))
        name = item.string('name')
        if name in [s.name for s in scenarios]:
            raise fail(item.path_of('name'), f'scenario {name!r} is listed twice')
        task_file = path.parent / item.string('task')
        try:
            task = load_formation_task(task_file)
        except ValueError as error:
            raise fail(item.path_of('task'), str(error)) from None
        goals = None
        if item.raw('goals', None) is not None:
            raw = item.raw('goals')
            if not isinstance(raw, dict) or not raw:
                raise fail(item.path_of('goals'), 'must map robot names to [x, y]')
            goals = {str(robot): check_vector(point, join_path(item.path_of('goals'), str(robot)), 2)
                     for robot, point in raw.items()}
        scenarios.append(CollabScenario(name, task, goals))
    return CollabConfig(
        source=path, control_rate=fields.number('control_rate', 10.0, gt=0.0),
        integration_substeps=fields.integer('integration_substeps', 5, ge=1),
        time_limit_factor=fields.number('time_limit_factor', 2.0, ge=1.0),
        methods=tuple(methods), scenarios=tuple(scenarios))


# ---------------------------------------------------------------------------------- measures
def pair_distances(positions: dict[str, np.ndarray]) -> dict[tuple[str, str], np.ndarray]:
    """Centre distance over time (K,) of every robot pair, from (K, 2) positions per robot."""
    names = sorted(positions)
    return {(a, b): np.hypot(*(positions[a] - positions[b]).T)
            for i, a in enumerate(names) for b in names[i + 1:]}


def contact_onsets(distance: np.ndarray, threshold: float) -> int:
    """How often ``distance`` drops below ``threshold`` (a contact that lasts counts once)."""
    inside = np.asarray(distance) < threshold
    return int(inside[0]) + int(np.count_nonzero(inside[1:] & ~inside[:-1])) if len(inside) else 0


def separation_measures(positions: dict[str, np.ndarray], radii: dict[str, float], times: np.ndarray) -> dict:
    """min_distance (centres) with its pair and sum of radii, min_clearance, collisions (onsets)."""
    distances = pair_distances(positions)
    if not distances:
        return {'min_distance': None, 'min_distance_pair': None, 'min_distance_time': None,
                'sum_of_radii': None, 'min_clearance': None, 'collisions': 0, 'collisions_by_pair': {}}
    closest = min(distances, key=lambda pair: float(distances[pair].min()))
    k = int(np.argmin(distances[closest]))
    clearances = {pair: d - (radii[pair[0]] + radii[pair[1]]) for pair, d in distances.items()}
    by_pair = {f'{a}-{b}': contact_onsets(d, radii[a] + radii[b]) for (a, b), d in distances.items()}
    return {'min_distance': float(distances[closest][k]), 'min_distance_pair': list(closest),
            'min_distance_time': float(times[k]), 'sum_of_radii': radii[closest[0]] + radii[closest[1]],
            'min_clearance': float(min(c.min() for c in clearances.values())),
            'collisions': int(sum(by_pair.values())), 'collisions_by_pair': by_pair}


def finite_difference_jerk(velocities: np.ndarray, dt: float) -> np.ndarray:
    """|jerk| (K-2,) of planar velocities (K, 2) sampled every ``dt``."""
    if len(velocities) < 3:
        return np.zeros(0)
    return np.hypot(*(np.diff(velocities, n=2, axis=0) / dt**2).T)


def hermite_jerk(role: SharedRole, t: float) -> float:
    """|d^3 p / dt^3| of the role's cubic Hermite interpolant (core/trajectory.py) at time ``t``; 0 at rest."""
    states = role.trajectory
    intervals = len(states) - 1
    dt = role.total_time / intervals
    local = t - role.start_time
    if local < 0.0 or local > role.total_time:
        return 0.0
    k = min(int(local / dt), intervals - 1)
    p0, v0, p1, v1 = states[k, :2], states[k, 2:] * dt, states[k + 1, :2], states[k + 1, 2:] * dt
    return float(np.hypot(*((12 * p0 + 6 * v0 - 12 * p1 + 6 * v1) / dt**3)))


# -------------------------------------------------------------------------------- simulation
@dataclass
class SimRobot:
    member: 'SimMember'
    limits: DiffDriveLimits
    pose: np.ndarray                      # x, y, yaw
    role: SharedRole
    follower: TrajectoryFollower
    velocity: tuple[float, float] = (0.0, 0.0)    # linear, angular actually applied
    arrived_at: float | None = None


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


def simulate(method: str, task: FormationTask, team: list[SimMember], environment: Environment,
             initial: dict[str, np.ndarray], config: CollabConfig) -> RunRecord:
    """One run of ``method`` from the initial roles (module docstring); roles start at t = 0."""
    if method not in METHODS:
        raise RoleEngineError(f"method: must be one of {', '.join(METHODS)} (got {method!r})")
    dt = 1.0 / config.control_rate
    robots: dict[str, SimRobot] = {}
    views, planners = {}, {}
    for member in team:
        role = SharedRole(member.name, initial[member.name], task.total_time, member.robot_type.radius, 0.0)
        robots[member.name] = SimRobot(member, member.limits, np.array(member.start, dtype=float), role,
                                       _follower(role, member, task))
        if member.robot_type.name not in views:
            views[member.robot_type.name] = environment.for_robot(member.robot_type)
            planners[member.robot_type.name] = task.gp_config(member.robot_type)
    record = RunRecord(method, np.zeros(0), {}, {}, {}, {}, goals={n: t[-1, :2] for n, t in initial.items()})
    times, positions, velocities, jerks = [], {n: [] for n in robots}, {n: [] for n in robots}, {n: [] for n in robots}
    limit = config.time_limit_factor * task.total_time
    replan_every = max(1, int(round(task.replan_period / dt)))
    step = 0
    while True:
        now = step * dt
        if step > 0 and step % replan_every == 0:
            _replan_all(method, robots, views, planners, task, now, record)
        times.append(now)
        for name, robot in robots.items():
            positions[name].append(robot.pose[:2].copy())
            v = robot.velocity[0]
            velocities[name].append([v * math.cos(robot.pose[2]), v * math.sin(robot.pose[2])])
            jerks[name].append(hermite_jerk(robot.role, now) if robot.arrived_at is None else 0.0)
        if all(r.arrived_at is not None for r in robots.values()) or now >= limit:
            break
        for robot in robots.values():
            _drive(robot, task, now, dt, config.integration_substeps)
        step += 1
    record.times = np.array(times)
    record.positions = {n: np.array(p) for n, p in positions.items()}
    record.velocities = {n: np.array(v) for n, v in velocities.items()}
    record.role_jerks = {n: np.array(j) for n, j in jerks.items()}
    record.arrived_at = {n: r.arrived_at for n, r in robots.items()}
    return record


def _follower(role: SharedRole, member: SimMember, task: FormationTask) -> TrajectoryFollower:
    return TrajectoryFollower(role.trajectory, role.total_time, member.robot_type,
                              position_tolerance=0.5 * task.arrival_tolerance)


def _replan_all(method, robots, views, planners, task, now, record) -> None:
    """Algorithm 4 lines 2-7 for every player from one snapshot of the channel."""
    if method == 'role_based':
        channel = {n: r.role for n, r in robots.items()}
    else:
        channel = {n: _at_rest(n, r.pose[:2], r.member.robot_type.radius, now) for n, r in robots.items()}
    adopted = {}
    for name, robot in robots.items():
        if robot.arrived_at is not None:
            continue
        others = [role for other, role in channel.items() if other != name]
        kind = robot.member.robot_type.name
        began = time.perf_counter()
        result = replan_process_role(planners[kind], views[kind], robot.role, others, now, robot.pose[:2],
                                     horizon=task.conflict_horizon, avoidance=task.robot_avoidance)
        record.replan_ms.append((time.perf_counter() - began) * 1e3)
        record.conflicts_seen += bool(result.conflicting)
        if result.trajectory is None:
            record.replans_kept += 1
            continue
        adopted[name] = SharedRole(name, result.trajectory, result.total_time, robot.role.radius, result.start_time)
    for name, role in adopted.items():
        robots[name].role = role
        robots[name].follower = _follower(role, robots[name].member, task)


def _drive(robot: SimRobot, task: FormationTask, now: float, dt: float, substeps: int) -> None:
    """One control step: the role_player node's command (or stop), limited as the bridge does, integrated."""
    if robot.arrived_at is not None:
        target = (0.0, 0.0)
    else:
        local = now - robot.role.start_time
        goal = robot.role.trajectory[-1, :2]
        if local >= robot.role.total_time and math.dist(robot.pose[:2], goal) <= task.arrival_tolerance:
            robot.arrived_at = now
            target = (0.0, 0.0)
        else:
            target = robot.follower.command(local, robot.pose)
    h = dt / substeps
    for _ in range(substeps):
        robot.velocity = limit_velocity(target, robot.velocity, robot.limits, h)
        v, w = robot.velocity
        yaw = robot.pose[2]
        if abs(w) < 1e-9:
            robot.pose[0] += v * h * math.cos(yaw)
            robot.pose[1] += v * h * math.sin(yaw)
        else:                                    # exact unicycle arc
            robot.pose[0] += v / w * (math.sin(yaw + w * h) - math.sin(yaw))
            robot.pose[1] -= v / w * (math.cos(yaw + w * h) - math.cos(yaw))
        robot.pose[2] = (yaw + w * h + math.pi) % (2 * math.pi) - math.pi


def run_measures(record: RunRecord, team: list[SimMember], environment: Environment, dt: float) -> dict:
    """The per-method results (module docstring)."""
    radii = {m.name: m.robot_type.radius for m in team}
    completed = all(t is not None for t in record.arrived_at.values())
    driven, played = [], []
    for name in record.positions:
        end = record.arrived_at[name]
        stop = len(record.times) if end is None else int(np.searchsorted(record.times, end)) + 1
        jerk = finite_difference_jerk(record.velocities[name][:stop], dt)
        driven.append(float(jerk.mean()) if len(jerk) else 0.0)
        played.append(float(record.role_jerks[name][:stop].mean()))
    obstacle = {name: contact_onsets(environment.sdf.distance(p), radii[name]) for name, p in record.positions.items()}
    return {
        'completed': completed,
        'completion_time': max(record.arrived_at.values()) if completed else None,
        'arrival_time': record.arrived_at,
        'average_jerk': float(np.mean(driven)), 'role_jerk': float(np.mean(played)),
        **separation_measures(record.positions, radii, record.times),
        'obstacle_contacts': int(sum(obstacle.values())), 'obstacle_contacts_by_robot': obstacle,
        'final_error': {n: float(np.hypot(*(p[-1] - record.goals[n]))) for n, p in record.positions.items()},
        'replans': len(record.replan_ms), 'replans_with_conflict': record.conflicts_seen,
        'replans_kept_role': record.replans_kept,
        'replan_ms_median': statistics.median(record.replan_ms) if record.replan_ms else None,
        'simulated_s': float(record.times[-1]),
    }


# ------------------------------------------------------------------------------------- driver
def run_collab(config_dir: str | Path, run_dir: str | Path, log: Log = print, *, only=None) -> dict:
    """Run every scenario (or ``only`` those) with every method; writes results.json, collab.md, plots."""
    config = load_collab_config(Path(config_dir) / CONFIG_FILE)
    run_dir = Path(run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    scenarios = [s for s in config.scenarios if not only or s.name in only]
    if only and len(scenarios) != len(set(only)):
        known = ', '.join(s.name for s in config.scenarios)
        raise RoleEngineError(f'--only: unknown scenario(s) {sorted(set(only) - {s.name for s in scenarios})} '
                              f'(known: {known})')
    dt = 1.0 / config.control_rate
    results = {'experiment': 'roles-collab', 'config': str(config.source),
               'simulation': 'core-level: kinematic differential-drive robots (bridge velocity/acceleration '
                             'limits), core trajectory follower, replan_process_role every replan_period, '
                             'exact positions (no camera noise); not pybullet',
               'control_rate_hz': config.control_rate, 'methods': list(config.methods), 'scenarios': {}}
    runs = {}
    for scenario in scenarios:
        task = scenario.task
        bridge_scenario, team = scenario_team(task)
        environment = environment_from_scenario(bridge_scenario, task.grid_resolution)
        began = time.perf_counter()
        initial = initial_process_roles(scenario, environment, team)
        log(f'[roles-collab] {scenario.name}: {len(team)} robots, initial process roles in '
            f'{time.perf_counter() - began:.1f} s')
        goals = {name: initial[name][-1, :2] for name in initial}
        entry = {'robots': {m.name: {'type': m.robot_type.name, 'radius': m.robot_type.radius,
                                     'start': list(m.start[:2]), 'goal': goals[m.name].tolist()} for m in team},
                 'total_time_s': task.total_time, 'replan_period_s': task.replan_period,
                 'conflict_horizon_s': task.conflict_horizon}
        for method in config.methods:
            began = time.perf_counter()
            record = simulate(method, task, team, environment, initial, config)
            measures = run_measures(record, team, environment, dt)
            measures['wall_s'] = time.perf_counter() - began
            entry[method] = measures
            runs[(scenario.name, method)] = record
            log(f"[roles-collab] {scenario.name} {method}: {'completed' if measures['completed'] else 'NOT completed'}"
                f" ({measures['simulated_s']:.1f} s simulated, {measures['wall_s']:.1f} s wall), average jerk "
                f"{measures['average_jerk']:.4f} m/s^3 (roles {measures['role_jerk']:.4f}), min distance "
                f"{measures['min_distance']:.3f} m (sum of radii {measures['sum_of_radii']:.3f}), collisions "
                f"{measures['collisions']}, obstacle contacts {measures['obstacle_contacts']}")
        results['scenarios'][scenario.name] = entry
        _plot_paths(scenario.name, entry, environment, team, {m: runs[(scenario.name, m)] for m in config.methods},
                    run_dir / f'{scenario.name}_paths.png')
        _plot_distances(scenario.name, team, {m: runs[(scenario.name, m)] for m in config.methods},
                        run_dir / f'{scenario.name}_distance.png')
    results['acceptance'] = collab_acceptance(results)
    (run_dir / 'results.json').write_text(json.dumps(results, indent=2) + '\n')
    (run_dir / 'collab.md').write_text(collab_markdown(results))
    log(f"[roles-collab] acceptance: {'passed' if results['acceptance']['passed'] else 'FAILED'} "
        f"({results['acceptance']['reason']})")
    return results


def collab_acceptance(results: dict) -> dict:
    """Role-based completes every scenario, no collision, min centre distance >= the pair's sum of radii,
    and no robot through a wall (the kinematic robots could drive through one, so a completed run that
    did would not be a pass)."""
    checks, failures = {}, []
    for name, entry in results['scenarios'].items():
        role = entry.get('role_based')
        if role is None:
            failures.append(f'{name}: role-based not run')
            continue
        ok = {'completed': role['completed'], 'no_collision': role['collisions'] == 0,
              'min_distance_at_least_sum_of_radii': role['min_clearance'] is None or role['min_clearance'] >= 0.0,
              'no_obstacle_contact': role['obstacle_contacts'] == 0}
        checks[name] = ok
        failures += [f'{name}: role-based {key.replace("_", " ")} is false' for key, value in ok.items() if not value]
    return {'passed': not failures, 'checks': checks, 'reason': '; '.join(failures) or 'every check holds'}


def collab_markdown(results: dict) -> str:
    lines = ['# Task-based vs role-based collaboration (paper Sec. V-A-3, V-A-4)', '',
             f"Simulation: {results['simulation']}.", '',
             '| scenario | method | completed | time s | average jerk m/s^3 (driven) | role jerk m/s^3 | '
             'min distance m (pair) | sum of radii m | min clearance m | collisions | obstacle contacts |',
             '|---|---|---|---|---|---|---|---|---|---|---|']
    for name, entry in results['scenarios'].items():
        for method in results['methods']:
            r = entry[method]
            time_text = f"{r['completion_time']:.1f}" if r['completed'] else f"not by {r['simulated_s']:.0f}"
            lines.append(f"| {name} | {method} | {'yes' if r['completed'] else 'NO'} | {time_text} | "
                         f"{r['average_jerk']:.4f} | {r['role_jerk']:.4f} | {r['min_distance']:.3f} "
                         f"({'-'.join(r['min_distance_pair'])}) | {r['sum_of_radii']:.3f} | {r['min_clearance']:.3f} | "
                         f"{r['collisions']} | {r['obstacle_contacts']} |")
    acceptance = results['acceptance']
    lines += ['', 'The paper (Sec. V-A-3): average jerk 0.006 (task-based) -> 0.0003 (role-based), minimum '
                  'distance 0.18 m -> 0.23 m (its units and robot sizes are not given).', '',
              f"Acceptance (role-based: completed, no collision, min distance >= sum of radii, no obstacle contact): "
              f"{'passed' if acceptance['passed'] else 'FAILED'} ({acceptance['reason']})."]
    return '\n'.join(lines) + '\n'


# --------------------------------------------------------------------------------------- plots
def pyplot():
    """matplotlib.pyplot on the Agg backend (imported only when plotting)."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    return plt


ROBOT_COLOURS = ['tab:red', 'tab:blue', 'tab:green', 'tab:orange', 'tab:purple', 'tab:brown']


def _plot_paths(name: str, entry: dict, environment: Environment, team, records: dict, path: Path) -> None:
    from matplotlib.patches import Circle
    plt = pyplot()
    x0, y0, x1, y1 = environment.frame.bounds
    aspect = (y1 - y0) / (x1 - x0)
    fig, axes = plt.subplots(1, len(records), figsize=(5.0 * len(records), 5.0 * aspect + 0.9), squeeze=False)
    for ax, (method, record) in zip(axes[0], records.items()):
        ax.imshow(np.where(environment.occupied, 0.0, 1.0), origin='lower', extent=(x0, x1, y0, y1), cmap='gray',
                  vmin=0.0, vmax=1.0, interpolation='nearest')
        for k, member in enumerate(team):
            colour = ROBOT_COLOURS[k % len(ROBOT_COLOURS)]
            p = record.positions[member.name]
            ax.plot(p[:, 0], p[:, 1], '-', color=colour, lw=1.3, label=member.name)
            ax.add_patch(Circle(p[0], member.robot_type.radius, fill=False, ec=colour, ls='--'))
            ax.add_patch(Circle(entry['robots'][member.name]['goal'], member.robot_type.radius, fill=False,
                                ec=colour, lw=1.5))
        r = entry[method]
        if r['min_distance_pair']:
            k = int(np.searchsorted(record.times, r['min_distance_time']))
            for robot in r['min_distance_pair']:
                radius = next(m.robot_type.radius for m in team if m.name == robot)
                ax.add_patch(Circle(record.positions[robot][k], radius, color='red', alpha=0.35))
        ax.set_title(f"{METHOD_LABEL[method]}\n{'completed' if r['completed'] else 'NOT completed'}, min distance "
                     f"{r['min_distance']:.2f} m, collisions {r['collisions']}", fontsize=9)
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
        ax.set_aspect('equal')
    axes[0][0].legend(fontsize=7, loc='best')
    fig.suptitle(f'{name}: driven paths (dashed: start, solid: goal, red: closest approach)', fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _plot_distances(name: str, team, records: dict, path: Path) -> None:
    plt = pyplot()
    radii = {m.name: m.robot_type.radius for m in team}
    fig, ax = plt.subplots(figsize=(7.0, 3.6))
    for style, (method, record) in zip(('--', '-'), records.items()):
        distances = pair_distances(record.positions)
        clearance = np.min([d - radii[a] - radii[b] for (a, b), d in distances.items()], axis=0)
        ax.plot(record.times, clearance, style, label=METHOD_LABEL[method])
    ax.axhline(0.0, color='red', lw=0.8)
    ax.set_xlabel('time (s)')
    ax.set_ylabel('min over pairs of\ndistance - sum of radii (m)')
    ax.set_title(f'{name}: closest pair over time (below 0: bodies overlap)', fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)

"""Task-based vs role-based collaboration (paper Sec. V-A-3, V-A-4): ``scripts/experiment roles-collab``.

Settings: ``config/roles/collab.yaml`` (:mod:`.collab_config`). Each scenario's initial process
roles are computed once and played by each method in the core-level simulation of
:mod:`.collab_simulation`, where every robot runs the role_player node's own
:class:`~role_engine.core.player.RolePlayer`. A robot has arrived when its role is over and it is
within the task's ``arrival_tolerance`` of its destination (the player decides, as on a robot).

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

import statistics
import time
from pathlib import Path

import numpy as np

from collab_tools.experiments import plots
from collab_tools.experiments.api import ExperimentRequest, ExperimentResult
from collab_tools.experiments.sweep import select

from ..core.environment import Environment, environment_from_scenario
from .collab_config import CONFIG_FILE, load_collab_config
from .collab_simulation import RunRecord, SimMember, initial_process_roles, scenario_team, simulate
from .path_measures import contact_onsets, finite_difference_jerk, pair_distances, separation_measures

METHOD_LABEL = {'task_based': 'task-based (last positions)', 'role_based': 'role-based (process roles)'}
SIMULATION = ('core-level: kinematic differential-drive robots (bridge velocity/acceleration limits), each driven '
              "by the role_player node's core RolePlayer (trajectory follower, replan_process_role every "
              'replan_period), exact positions (no camera noise); not pybullet')


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



def run(request: ExperimentRequest) -> ExperimentResult:
    """Every scenario (or ``--only`` those) with every method; writes collab.md and the plots."""
    config = load_collab_config(Path(request.config_dir) / CONFIG_FILE)
    run_dir, log = Path(request.run_dir), request.log
    scenarios = select(config.scenarios, request.option('only'), lambda s: s.name, 'scenario')
    dt = 1.0 / config.control_rate
    results = {'config': str(config.source), 'simulation': SIMULATION, 'control_rate_hz': config.control_rate,
               'methods': list(config.methods), 'scenarios': {}}
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
    acceptance = collab_acceptance(results)
    report = collab_markdown(results, acceptance)
    log(f"[roles-collab] acceptance: {'passed' if acceptance['passed'] else 'FAILED'} ({acceptance['reason']})")
    return ExperimentResult(acceptance['passed'], collab_outcome(results, acceptance), report, acceptance, results,
                            report_file='collab.md')


def collab_outcome(results: dict, acceptance: dict) -> str:
    """Per scenario the role-based run's key figures (the task-based one's collisions beside them); a failed
    acceptance says why."""
    parts = []
    for name, entry in results['scenarios'].items():
        role, task = entry.get('role_based'), entry.get('task_based')
        text = name + ': role-based ' + ('not run' if role is None else
                                         f"{'completed' if role['completed'] else 'NOT completed'}, min distance "
                                         f"{role['min_distance']:.3f} m, {role['collisions']} collisions")
        if task is not None:
            text += f" (task-based {task['collisions']})"
        parts.append(text)
    text = '; '.join(parts)
    return text if acceptance['passed'] else f"{text}; {acceptance['reason']}"


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


def collab_markdown(results: dict, acceptance: dict) -> str:
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
    lines += ['', 'The paper (Sec. V-A-3): average jerk 0.006 (task-based) -> 0.0003 (role-based), minimum '
                  'distance 0.18 m -> 0.23 m (its units and robot sizes are not given).', '',
              f"Acceptance (role-based: completed, no collision, min distance >= sum of radii, no obstacle contact): "
              f"{'passed' if acceptance['passed'] else 'FAILED'} ({acceptance['reason']})."]
    return '\n'.join(lines) + '\n'



def _plot_paths(name: str, entry: dict, environment: Environment, team, records: dict, path: Path) -> None:
    from matplotlib.patches import Circle
    x0, y0, x1, y1 = environment.frame.bounds
    aspect = (y1 - y0) / (x1 - x0)
    fig, axes = plots.figure(5.0 * len(records), 5.0 * aspect + 0.9, columns=len(records), squeeze=False)
    for ax, (method, record) in zip(axes[0], records.items()):
        ax.imshow(np.where(environment.occupied, 0.0, 1.0), origin='lower', extent=(x0, x1, y0, y1), cmap='gray',
                  vmin=0.0, vmax=1.0, interpolation='nearest')
        for member in team:
            colour = member.color   # as the robot looks in the simulation (its scenario's colour)
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
    plots.save(fig, path)


def _plot_distances(name: str, team, records: dict, path: Path) -> None:
    radii = {m.name: m.robot_type.radius for m in team}
    fig, ax = plots.figure(7.0, 3.6)
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
    plots.save(fig, path)

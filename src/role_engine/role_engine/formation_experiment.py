"""The diamond formation in simulation, recorded, measured from the bag (``scripts/experiment roles-formation``).

Runs ``config/experiments/roles_formation.yaml`` (pybullet bridge + role_engine + robot_tracker + one
role_player per robot, every topic of interest recorded) the way SGCM's simulated experiments do
(:func:`collab_tools.orchestration.experiment.run_experiment`), then reads the bag:

- ``/roles/assignment``: the negotiation rounds (who plays which role, goals, excluded robots);
- ``/roles/channel``: every process role published (the engine's initial ones, version 0, and
  the players' re-optimised ones), i.e. the *commanded* trajectories; ``arrived`` flags;
- ``/ground_truth/bodies``: the robots' true positions (the *tracked* trajectories of the plots
  and every distance measure: the camera tracker's estimates are not recorded, the truth is
  what a collision is about);
- ``/<robot>/cmd_vel``: the controller's commands.

Results (``results.json``): ``completed`` (the last round assigned roles and every robot of it
reported ``arrived``), ``min_distance`` (least ground-truth distance between two robot centres
over the whole recording) with its pair and ``sum_of_radii``, ``min_clearance`` (least
distance minus the pair's sum of radii), ``collisions`` (onsets of a pair closer than its sum
of radii), and per robot of the last round its role, goal, ``arrival_time`` (s from the round's
role start to the player's ``arrived`` message), ``final_error`` (ground-truth distance to the
goal at the end) and the tracking error (ground truth vs the commanded role at the same time).

``--stop-player <robot>``: the same run, but once that robot's player (``/<robot>/role_player``) has
published ``stop_after_versions`` re-optimised roles, its node is stopped (SIGINT); the role engine must
notice the silence, renegotiate with the others, and they must complete the formation. This
needs a step "stop a node once a message matches" that the experiment YAML cannot express, so
that variant drives a :class:`~collab_tools.orchestration.session.Session` itself from the same
experiment file.
"""
from __future__ import annotations

import json
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np
import yaml

from collab_tools.core.bag_analysis import read_messages

from .collab_experiment import ROBOT_COLOURS, pyplot, separation_measures
from .core.trajectory import interpolate

Log = Callable[[str], None]

EXPERIMENT_FILE = 'experiments/roles_formation.yaml'
ASSIGNMENT = '/roles/assignment'
CHANNEL = '/roles/channel'
GROUND_TRUTH = '/ground_truth/bodies'


def _stamp(header) -> float:
    return header.stamp.sec + header.stamp.nanosec * 1e-9


# ------------------------------------------------------------------------------- bag reading
@dataclass(frozen=True)
class AssignmentRecord:
    stamp: float
    round: int
    status: str
    message: str
    goals: dict[str, tuple[float, float]]      # robot -> goal
    role_ids: dict[str, str]
    excluded: list[str]
    start_time: float | None                    # the round's roles' start time (s, sim clock)


@dataclass(frozen=True)
class RoleRecord:
    stamp: float
    round: int
    version: int
    start_time: float
    total_time: float
    trajectory: np.ndarray
    arrived: bool

    def position(self, t: float) -> np.ndarray:
        return interpolate(self.trajectory, self.total_time, [t - self.start_time])[0][0]


@dataclass
class FormationLog:
    """What one recorded run holds, per robot."""

    assignments: list[AssignmentRecord] = field(default_factory=list)
    roles: dict[str, list[RoleRecord]] = field(default_factory=dict)
    truth_times: np.ndarray = field(default_factory=lambda: np.zeros(0))
    truth: dict[str, np.ndarray] = field(default_factory=dict)          # (K, 2) per robot
    commands: dict[str, np.ndarray] = field(default_factory=dict)       # (M, 3): t, linear, angular


def _role_record(msg) -> RoleRecord:
    states = np.column_stack([msg.x, msg.y, msg.vx, msg.vy]).astype(float)
    if len(states) < 2 or not (msg.dt > 0):
        raise ValueError(f'process role of {msg.robot!r} (round {msg.round}, version {msg.version}): needs >= 2 '
                         f'states and dt > 0 (got {len(states)}, {msg.dt})')
    return RoleRecord(_stamp(msg.header), int(msg.round), int(msg.version), float(msg.start_time),
                      float(msg.dt) * (len(states) - 1), states, bool(msg.arrived))


def read_formation_bag(bag: Path, robots: list[str]) -> FormationLog:
    """The run's assignments, roles, ground truth and commands of ``robots`` (bag time order)."""
    command_topics = {f'/{robot}/cmd_vel': robot for robot in robots}
    log = FormationLog(roles={r: [] for r in robots})
    truth_times, truth = [], {r: [] for r in robots}
    commands = {r: [] for r in robots}
    for topic, log_ns, msg in read_messages(bag, [ASSIGNMENT, CHANNEL, GROUND_TRUTH, *command_topics]):
        if topic == ASSIGNMENT:
            starts = {r.start_time for r in msg.initial_roles}
            log.assignments.append(AssignmentRecord(
                _stamp(msg.header), int(msg.round), msg.status, msg.message,
                {r: (float(x), float(y)) for r, x, y in zip(msg.robots, msg.goal_x, msg.goal_y)},
                dict(zip(msg.robots, msg.role_ids)), list(msg.excluded_robots),
                min(starts) if starts else None))
        elif topic == CHANNEL:
            if msg.robot in log.roles:
                log.roles[msg.robot].append(_role_record(msg))
        elif topic == GROUND_TRUTH:
            seen = {b.name: b.pose.position for b in msg.bodies}
            if all(r in seen for r in robots):
                truth_times.append(_stamp(msg.header))
                for r in robots:
                    truth[r].append([seen[r].x, seen[r].y])
        else:
            commands[command_topics[topic]].append([log_ns * 1e-9, msg.linear.x, msg.angular.z])
    order = np.argsort(truth_times, kind='stable')
    log.truth_times = np.asarray(truth_times, dtype=float)[order]
    log.truth = {r: np.asarray(p, dtype=float).reshape(-1, 2)[order] for r, p in truth.items()}
    log.commands = {r: np.asarray(c, dtype=float).reshape(-1, 3) for r, c in commands.items()}
    return log


def commanded_positions(roles: list[RoleRecord], times: np.ndarray, round_: int | None = None) -> np.ndarray:
    """(K, 2) position of the role in force at each time (the latest one stamped <= t; NaN before any)."""
    chosen = sorted((r for r in roles if round_ is None or r.round == round_), key=lambda r: r.stamp)
    out = np.full((len(times), 2), np.nan)
    stamps = np.array([r.stamp for r in chosen])
    for k, t in enumerate(times):
        index = int(np.searchsorted(stamps, t, side='right')) - 1
        if index >= 0:
            out[k] = chosen[index].position(t)
    return out


# ----------------------------------------------------------------------------------- results
def formation_results(log: FormationLog, radii: dict[str, float], arrival_tolerance: float) -> dict:
    """results.json of a run from its bag (module docstring); never raises on an unfinished run."""
    robots = sorted(radii)
    if len(log.truth_times) == 0:
        raise ValueError(f'the bag has no {GROUND_TRUTH} message with every robot ({", ".join(robots)})')
    separation = separation_measures(log.truth, radii, log.truth_times)
    final = max(log.assignments, key=lambda a: a.round) if log.assignments else None
    results = {'rounds': [{'round': a.round, 'status': a.status, 'message': a.message, 'robots': sorted(a.goals),
                           'excluded': a.excluded} for a in sorted(log.assignments, key=lambda a: a.round)],
               **separation, 'recorded_s': float(log.truth_times[-1] - log.truth_times[0]), 'robots': {}}
    assigned = final is not None and final.status == 'assigned'
    completed = assigned
    for robot in (sorted(final.goals) if assigned else []):
        roles = [r for r in log.roles.get(robot, []) if r.round == final.round]
        arrived = next((r for r in sorted(roles, key=lambda r: r.stamp) if r.arrived), None)
        goal = np.asarray(final.goals[robot])
        final_error = float(np.hypot(*(log.truth[robot][-1] - goal)))
        in_round = log.truth_times >= (final.start_time if final.start_time is not None else final.stamp)
        commanded = commanded_positions(roles, log.truth_times[in_round])
        valid = ~np.isnan(commanded[:, 0])
        error = np.hypot(*(commanded[valid] - log.truth[robot][in_round][valid]).T)
        results['robots'][robot] = {
            'role_id': final.role_ids[robot], 'goal': goal.tolist(), 'radius': radii[robot],
            'arrived': arrived is not None,
            'arrival_time': None if arrived is None or final.start_time is None
            else arrived.stamp - final.start_time,
            'final_error': final_error, 'within_tolerance': final_error <= arrival_tolerance,
            'tracking_error_rms': float(np.sqrt(np.mean(error**2))) if len(error) else None,
            'tracking_error_max': float(error.max()) if len(error) else None,
            'process_roles_published': len(roles)}
        completed = completed and arrived is not None
    results.update({'completed': bool(completed), 'final_round': final.round if final else None,
                    'final_status': final.status if final else 'no assignment', 'arrival_tolerance': arrival_tolerance})
    return results


def formation_acceptance(results: dict, stopped: str | None = None) -> dict:
    """Completed, no collision (distance never below the sum of radii); with a stopped player also:
    renegotiated without it."""
    checks = {'completed': results['completed'], 'no_collision': results['collisions'] == 0,
              'min_distance_at_least_sum_of_radii': results['min_clearance'] >= 0.0}
    if stopped is not None:
        final = results['rounds'][-1] if results['rounds'] else {}
        checks['renegotiated_without_stopped'] = (results['final_round'] or 0) >= 2 and stopped in final.get(
            'excluded', []) and stopped not in final.get('robots', [stopped])
    failures = [name for name, ok in checks.items() if not ok]
    return {'passed': not failures, 'checks': checks,
            'reason': 'every check holds' if not failures else 'failed: ' + ', '.join(failures)}


# ------------------------------------------------------------------------------------ running
def run_formation(config_dir: str | Path, run_dir: str | Path, log: Log = print, *, stop_player: str | None = None,
                  stop_after_versions: int = 5) -> dict:
    """Run the orchestrated formation (optionally stopping one player), then measure it from the bag."""
    from pybullet_bridge.core.scenario import load_scenario

    from .core.formation_task import load_formation_task, team_from_scenario

    config_dir, run_dir = Path(config_dir), Path(run_dir)
    experiment = config_dir / EXPERIMENT_FILE
    task = load_formation_task(config_dir / 'roles' / 'formation_demo.yaml')
    team = team_from_scenario(load_scenario(task.scenario), task.inflation_margin)
    radii = {m.name: m.robot_type.radius for m in team}
    if stop_player is not None and stop_player not in radii:
        raise ValueError(f"--stop-player: must be one of {', '.join(radii)} (got {stop_player!r})")
    quiet = lambda _text: None  # noqa: E731  (the session's own lines would drown the progress)
    log(f"[roles-formation] running {experiment.name} in simulation ({len(team)} robots"
        + (f', stopping {stop_player} after {stop_after_versions} re-plans' if stop_player else '') + f'): {run_dir}')
    began = time.monotonic()
    if stop_player is None:
        from collab_tools.orchestration.experiment import run_experiment
        outcome = run_experiment(experiment, config_dir, run_dir=run_dir, log=quiet)
        bag, message, exit_code = outcome.bag, outcome.message, outcome.exit_code
    else:
        bag, message, exit_code = _run_with_stop(experiment, config_dir, run_dir, stop_player, stop_after_versions,
                                                 log)
    wall = time.monotonic() - began
    log(f'[roles-formation] session ended after {wall:.0f} s wall: {message} (exit code {exit_code})')
    if bag is None or not (bag / 'metadata.yaml').is_file():
        raise RuntimeError(f'no bag recorded ({message}); logs in {run_dir / "logs"}')
    flog = read_formation_bag(bag, sorted(radii))
    results = formation_results(flog, radii, task.arrival_tolerance)
    results.update({'experiment': 'roles-formation', 'mode': 'sim', 'bag': str(bag), 'session_message': message,
                    'session_exit_code': exit_code, 'wall_s': wall, 'stopped_player': stop_player,
                    'positions_from': 'role players: robot_tracker (camera colour tracking); measures: ground truth'})
    results['acceptance'] = formation_acceptance(results, stop_player)
    (run_dir / 'results.json').write_text(json.dumps(results, indent=2) + '\n')
    (run_dir / 'formation.md').write_text(formation_markdown(results))
    plot_commanded_vs_tracked(flog, results, run_dir / 'commanded_vs_tracked.png')
    plot_commands(flog, run_dir / 'cmd_vel.png')
    return results


def player_label(data: dict, robot: str, where: object = 'experiment') -> str:
    """The session label of ``robot``'s role player in a loaded experiment: the role_player node that
    runs in the robot's namespace (``/<robot>/role_player``); ValueError when there is none."""
    from collab_tools.orchestration.experiment import parse_node

    for index, node in enumerate(data.get('nodes') or []):
        spec = parse_node(node, f'nodes[{index}]')
        if spec.executable == 'role_player' and (spec.namespace or '').strip('/') == robot:
            return spec.label
    raise ValueError(f'{where}: no role_player node runs in the namespace /{robot}')


def _run_with_stop(experiment: Path, config_dir: Path, run_dir: Path, robot: str, versions: int, log: Log):
    """The experiment with two more after_start steps: once ``robot``'s player has published
    ``versions`` re-optimised roles, stop that player; the run then waits for the engine as usual."""
    from collab_tools.orchestration.experiment import load_experiment, run_experiment

    data = load_experiment(experiment)
    player = player_label(data, robot, experiment)
    data['after_start'] = list(data.get('after_start') or []) + [
        {'wait_for_message': {'topic': CHANNEL, 'type': 'role_interfaces/msg/ProcessRole',
                              'timeout': float(data.get('timeout', 300)),
                              'equals': {'robot': robot}, 'at_least': {'version': versions}}},
        {'stop': player}]
    run_dir.mkdir(parents=True, exist_ok=True)
    generated = run_dir / 'experiment.yaml'
    generated.write_text(yaml.safe_dump(data, sort_keys=False))
    log(f'[roles-formation] stopping {player} once {robot} has published {versions} re-optimised roles')
    outcome = run_experiment(generated, config_dir, run_dir=run_dir, log=lambda _text: None)
    return outcome.bag, outcome.message, outcome.exit_code


# ------------------------------------------------------------------------------- table, plots
def formation_markdown(results: dict) -> str:
    lines = ['# Diamond formation in simulation (paper Sec. V-B, Figs. 15-16)', '',
             f"completed: {'yes' if results['completed'] else 'NO'} (round {results['final_round']}, "
             f"{results['final_status']}); min distance between centres {results['min_distance']:.3f} m "
             f"({'-'.join(results['min_distance_pair'] or [])}, sum of radii {results['sum_of_radii']:.3f} m, "
             f"clearance {results['min_clearance']:.3f} m); collisions {results['collisions']}", '',
             '| robot | role | arrived | arrival time s | final error m | tracking error rms / max m |',
             '|---|---|---|---|---|---|']
    for robot, r in results['robots'].items():
        arrival = f"{r['arrival_time']:.1f}" if r['arrival_time'] is not None else '-'
        tracking = (f"{r['tracking_error_rms']:.3f} / {r['tracking_error_max']:.3f}"
                    if r['tracking_error_rms'] is not None else '-')
        lines.append(f"| {robot} | {r['role_id']} | {'yes' if r['arrived'] else 'NO'} | {arrival} | "
                     f"{r['final_error']:.3f} | {tracking} |")
    if results.get('stopped_player'):
        lines += ['', f"Stopped player: {results['stopped_player']}; rounds: "
                  + '; '.join(f"{r['round']} {r['status']} ({r['message']})" for r in results['rounds'])]
    acceptance = results.get('acceptance')
    if acceptance:
        lines += ['', f"Acceptance: {'passed' if acceptance['passed'] else 'FAILED'} ({acceptance['reason']})."]
    return '\n'.join(lines) + '\n'


def plot_commanded_vs_tracked(log: FormationLog, results: dict, path: Path) -> None:
    """Fig. 15: commanded (+, the role in force) and actual (., ground truth) positions of every robot."""
    plt = pyplot()
    fig, (ax, ax_err) = plt.subplots(1, 2, figsize=(12.0, 5.4))
    for k, robot in enumerate(sorted(log.truth)):
        colour = ROBOT_COLOURS[k % len(ROBOT_COLOURS)]
        truth = log.truth[robot]
        commanded = commanded_positions(log.roles.get(robot, []), log.truth_times)
        step = max(1, len(truth) // 150)
        ax.plot(truth[::step, 0], truth[::step, 1], '.', color=colour, ms=3, label=f'{robot} actual')
        ax.plot(commanded[::step, 0], commanded[::step, 1], '+', color=colour, ms=5, alpha=0.6,
                label=f'{robot} commanded')
        if robot in results['robots']:
            ax.plot(*results['robots'][robot]['goal'], 'o', mfc='none', mec=colour, ms=12)
        error = np.hypot(*(commanded - truth).T)
        ax_err.plot(log.truth_times - log.truth_times[0], error, '-', color=colour, lw=1, label=robot)
    ax.set_aspect('equal')
    ax.set_xlabel('x (m)')
    ax.set_ylabel('y (m)')
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    ax.set_title('commanded (+, process role in force) vs actual (., ground truth); o: goals', fontsize=9)
    ax_err.set_xlabel('time since the first ground-truth message (s)')
    ax_err.set_ylabel('|commanded - actual| (m)')
    ax_err.set_title('tracking error', fontsize=9)
    ax_err.grid(alpha=0.3)
    ax_err.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_commands(log: FormationLog, path: Path) -> None:
    """The recorded cmd_vel of every robot (linear and angular) over time."""
    plt = pyplot()
    fig, (ax_v, ax_w) = plt.subplots(2, 1, figsize=(9.0, 5.4), sharex=True)
    t0 = log.truth_times[0] if len(log.truth_times) else 0.0
    for k, (robot, commands) in enumerate(sorted(log.commands.items())):
        if len(commands) == 0:
            continue
        colour = ROBOT_COLOURS[k % len(ROBOT_COLOURS)]
        ax_v.plot(commands[:, 0] - t0, commands[:, 1], '-', color=colour, lw=1, label=robot)
        ax_w.plot(commands[:, 0] - t0, commands[:, 2], '-', color=colour, lw=1, label=robot)
    ax_v.set_ylabel('linear (m/s)')
    ax_w.set_ylabel('angular (rad/s)')
    ax_w.set_xlabel('time since the first ground-truth message (s, bag clock)')
    for ax in (ax_v, ax_w):
        ax.grid(alpha=0.3)
    ax_v.legend(fontsize=7, ncol=4)
    ax_v.set_title('cmd_vel as recorded', fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)

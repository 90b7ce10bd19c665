"""The diamond formation in simulation, recorded, measured from the bag (paper Sec. V-B, Figs. 15-16):
``scripts/experiment roles-formation [--stop-player <robot>]``.

Runs ``config/experiments/roles_formation.yaml`` (pybullet bridge + role_engine + robot_tracker + one
role_player per robot, every topic of interest recorded) through the orchestration library
(:func:`collab_tools.orchestration.experiment.run_experiment`), then reads the bag and measures
the run (:mod:`.formation_bag`). Writes ``formation.md``, ``commanded_vs_tracked.png`` and
``cmd_vel.png``.

``--stop-player <robot>``: the same run, but once that robot's player (``/<robot>/role_player``) has
published ``stop_after_versions`` re-optimised roles, its node is stopped (SIGINT); the role engine must
notice the silence, renegotiate with the others, and they must complete the formation. This
needs a step "stop a node once a message matches" that the experiment YAML cannot express, so
that variant runs a generated copy of the experiment file with two more ``after_start`` steps.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import yaml

from collab_tools.experiments import plots
from collab_tools.experiments.api import ExperimentRequest, ExperimentResult, Log

from .collab import ROBOT_COLOURS
from .formation_bag import CHANNEL, FormationLog, commanded_positions, formation_results, read_formation_bag

EXPERIMENT_FILE = 'experiments/roles_formation.yaml'
#: Re-optimised roles the stopped player publishes before it is stopped.
STOP_AFTER_VERSIONS = 5


def run(request: ExperimentRequest) -> ExperimentResult:
    """Run the orchestrated formation (optionally stopping one player), then measure it from the bag."""
    from pybullet_bridge.core.scenario import load_scenario

    from ..core.formation_task import load_formation_task, team_from_scenario

    config_dir, run_dir, log = Path(request.config_dir), Path(request.run_dir), request.log
    stop_player = request.option('stop_player')
    stop_after_versions = request.option('stop_after_versions', STOP_AFTER_VERSIONS)
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
    results.update({'mode': 'sim', 'bag': str(bag), 'session_message': message, 'session_exit_code': exit_code,
                    'session_wall_s': wall, 'stopped_player': stop_player,
                    'positions_from': 'role players: robot_tracker (camera colour tracking); measures: ground truth'})
    acceptance = formation_acceptance(results, stop_player)
    report = formation_markdown(results, acceptance)
    (run_dir / 'formation.md').write_text(report)
    plot_commanded_vs_tracked(flog, results, run_dir / 'commanded_vs_tracked.png')
    plot_commands(flog, run_dir / 'cmd_vel.png')
    return ExperimentResult(acceptance['passed'], acceptance['reason'], report, acceptance, results)


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
def formation_markdown(results: dict, acceptance: dict | None = None) -> str:
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
    if acceptance:
        lines += ['', f"Acceptance: {'passed' if acceptance['passed'] else 'FAILED'} ({acceptance['reason']})."]
    return '\n'.join(lines) + '\n'


def plot_commanded_vs_tracked(log: FormationLog, results: dict, path: Path) -> None:
    """Fig. 15: commanded (+, the role in force) and actual (., ground truth) positions of every robot."""
    fig, (ax, ax_err) = plots.figure(12.0, 5.4, columns=2)
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
    plots.save(fig, path)


def plot_commands(log: FormationLog, path: Path) -> None:
    """The recorded cmd_vel of every robot (linear and angular) over time."""
    fig, (ax_v, ax_w) = plots.figure(9.0, 5.4, rows=2, sharex=True)
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
    plots.save(fig, path)

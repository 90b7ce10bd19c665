"""The diamond formation in simulation, recorded, measured from the bag (paper Sec. V-B, Figs. 15-16):
``scripts/experiment roles-formation [--settings FILE] [--map NAV2_YAML] [--stop-player <robot>]``.

``--settings`` (the team and the role nodes' settings) and ``--map`` (a Nav2 map YAML: the
simulated obstacles) are read and validated first (:mod:`.formation_inputs`). Runs
``config/experiments/roles_formation.yaml`` (pybullet bridge + role_engine + robot_tracker + one
role_player per robot, every topic of interest recorded) through the orchestration library
(:func:`collab_tools.orchestration.experiment.run_experiment`), then reads the bag and measures
the run (:mod:`.formation_bag`: robot-robot distances and the robot-obstacle clearance of the
ground truth against the scenario's boxes, map cells and walls; a contact of either kind is a
collision). Writes ``formation.md``, ``commanded_vs_tracked.png`` and
``cmd_vel.png``.

``--stop-player <robot>``: the same run, but once that robot's player (``/<robot>/role_player``) has
published ``stop_after_versions`` re-optimised roles, its node is stopped (SIGINT); the role engine must
notice the silence, renegotiate with the others, and they must complete the formation. This
needs a step "stop a node once a message matches" that the experiment YAML cannot express, so
that variant runs a generated copy of the experiment file with two more ``after_start`` steps.
The acceptance: completed, no collision, min robot distance >= sum of radii, min obstacle clearance > 0.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import yaml

from collab_tools.core.report_plots import draw_scene, frame_scene, robot_colours
from collab_tools.core.scene_layout import SceneLayout
from collab_tools.experiments import plots
from collab_tools.experiments.api import ExperimentRequest, ExperimentResult

from ..core.errors import RoleEngineError
from .formation_bag import CHANNEL, FormationLog, commanded_positions, formation_results, read_formation_bag
from .formation_inputs import EXPERIMENT_FILE, formation_inputs
#: Re-optimised roles the stopped player publishes before it is stopped.
STOP_AFTER_VERSIONS = 5


def run(request: ExperimentRequest) -> ExperimentResult:
    """Run the orchestrated formation (optionally on another team or map, or stopping one player), then
    measure it from the bag. Every input is loaded and validated before a node starts."""
    from collab_tools.orchestration.experiment import run_experiment

    config_dir, run_dir, log = Path(request.config_dir), Path(request.run_dir), request.log
    stop_player = request.option('stop_player')
    stop_after_versions = request.option('stop_after_versions', STOP_AFTER_VERSIONS)
    inputs = formation_inputs(config_dir, run_dir, settings=request.option('settings'),
                              map_yaml=request.option('map'))
    task, radii = inputs.task, inputs.radii
    if stop_player is not None and stop_player not in radii:
        raise RoleEngineError(f"--stop-player: must be one of {', '.join(radii)} (got {stop_player!r})")
    experiment = config_dir / EXPERIMENT_FILE
    data = inputs.experiment
    if stop_player is not None:
        data = with_stop(data, stop_player, stop_after_versions, experiment)
    if inputs.generated or stop_player is not None:
        run_dir.mkdir(parents=True, exist_ok=True)
        experiment = run_dir / 'experiment.yaml'
        experiment.write_text(yaml.safe_dump(data, sort_keys=False))
    log(f"[roles-formation] running {experiment.name} in simulation ({len(radii)} robots, scenario "
        f"{inputs.scenario_file.name}, {len(inputs.obstacles)} obstacle boxes"
        + (f', stopping {stop_player} after {stop_after_versions} re-plans' if stop_player else '') + f'): {run_dir}')
    began = time.monotonic()
    outcome = run_experiment(experiment, config_dir, run_dir=run_dir, log=lambda _text: None)
    bag, message, exit_code = outcome.bag, outcome.message, outcome.exit_code
    wall = time.monotonic() - began
    log(f'[roles-formation] session ended after {wall:.0f} s wall: {message} (exit code {exit_code})')
    if bag is None or not (bag / 'metadata.yaml').is_file():
        raise RuntimeError(f'no bag recorded ({message}); logs in {run_dir / "logs"}')
    flog = read_formation_bag(bag, sorted(radii))
    results = formation_results(flog, radii, task.arrival_tolerance, inputs.obstacles)
    results.update({'mode': 'sim', 'bag': str(bag), 'session_message': message, 'session_exit_code': exit_code,
                    'session_wall_s': wall, 'stopped_player': stop_player,
                    'settings_file': str(task.source), 'scenario_file': str(inputs.scenario_file),
                    'map': str(Path(request.option('map')).resolve()) if request.option('map') else None,
                    'positions_from': 'role players: robot_tracker (camera colour tracking); measures: ground truth'})
    acceptance = formation_acceptance(results, stop_player)
    report = formation_markdown(results, acceptance)
    scene = plots.bag_scene(bag)   # the world as the simulation drew it: walls, boxes/map, robots' colours
    plot_commanded_vs_tracked(flog, results, run_dir / 'commanded_vs_tracked.png', scene)
    plot_commands(flog, run_dir / 'cmd_vel.png', scene)
    return ExperimentResult(acceptance['passed'], formation_outcome(results, acceptance), report, acceptance,
                            results, report_file='formation.md')


def formation_acceptance(results: dict, stopped: str | None = None) -> dict:
    """Completed, no collision (no robot-robot contact and no robot-obstacle contact; robot distances
    never below the sum of radii; obstacle clearance > 0); with a stopped player also: renegotiated
    without it."""
    obstacle = results.get('min_obstacle_clearance')
    checks = {'completed': results['completed'], 'no_collision': results['collisions'] == 0,
              'min_distance_at_least_sum_of_radii': results['min_clearance'] >= 0.0,
              'min_obstacle_clearance_positive': obstacle is None or obstacle > 0.0}
    if stopped is not None:
        final = results['rounds'][-1] if results['rounds'] else {}
        checks['renegotiated_without_stopped'] = (results['final_round'] or 0) >= 2 and stopped in final.get(
            'excluded', []) and stopped not in final.get('robots', [stopped])
    failures = [name for name, ok in checks.items() if not ok]
    return {'passed': not failures, 'checks': checks,
            'reason': 'every check holds' if not failures else 'failed: ' + ', '.join(failures)}



def formation_outcome(results: dict, acceptance: dict) -> str:
    """The run in one line, key figures first (the report's outcome line); a failed acceptance says why."""
    arrived = sum(1 for r in results['robots'].values() if r['arrived'])
    text = (f"{'formed' if results['completed'] else 'NOT formed'}: {arrived}/{len(results['robots'])} robots "
            f"arrived (round {results['final_round']}); min distance {results['min_distance']:.3f} m "
            f"(clearance {results['min_clearance']:.3f} m), {results['collisions']} collisions, min obstacle "
            f"clearance {_mm(results.get('min_obstacle_clearance'))}")
    return text if acceptance['passed'] else f"{text}; {acceptance['reason']}"


def player_label(data: dict, robot: str, where: object = 'experiment') -> str:
    """The session label of ``robot``'s role player in a loaded experiment: the role_player node that
    runs in the robot's namespace (``/<robot>/role_player``); ValueError when there is none."""
    from collab_tools.orchestration.experiment import parse_node

    for index, node in enumerate(data.get('nodes') or []):
        spec = parse_node(node, f'nodes[{index}]')
        if spec.executable == 'role_player' and (spec.namespace or '').strip('/') == robot:
            return spec.label
    raise ValueError(f'{where}: no role_player node runs in the namespace /{robot}')


def with_stop(data: dict, robot: str, versions: int, where: object = 'experiment') -> dict:
    """The experiment with two more after_start steps: once ``robot``'s player has published
    ``versions`` re-optimised roles, stop that player; the run then waits for the engine as usual."""
    player = player_label(data, robot, where)
    data = dict(data)
    data['after_start'] = list(data.get('after_start') or []) + [
        {'wait_for_message': {'topic': CHANNEL, 'type': 'role_interfaces/msg/ProcessRole',
                              'timeout': float(data.get('timeout', 300)),
                              'equals': {'robot': robot}, 'at_least': {'version': versions}}},
        {'stop': player}]
    return data


# ------------------------------------------------------------------------------- table, plots
def formation_markdown(results: dict, acceptance: dict | None = None) -> str:
    lines = ['# Diamond formation in simulation (paper Sec. V-B, Figs. 15-16)', '',
             f"completed: {'yes' if results['completed'] else 'NO'} (round {results['final_round']}, "
             f"{results['final_status']}); min distance between centres {results['min_distance']:.3f} m "
             f"({'-'.join(results['min_distance_pair'] or [])}, sum of radii {results['sum_of_radii']:.3f} m, "
             f"clearance {results['min_clearance']:.3f} m); collisions {results['collisions']} "
             f"({results.get('robot_collisions', results['collisions'])} robot-robot, "
             f"{results.get('obstacle_contacts', 0)} robot-obstacle)", '',
             'min robot-obstacle clearance (ground truth against the map\'s boxes and the walls, minus the '
             f"robot's radius): {_mm(results.get('min_obstacle_clearance'))}"
             + (f" ({results['min_obstacle_clearance_robot']})" if results.get('min_obstacle_clearance_robot') else ''),
             '',
             '| robot | role | arrived | arrival time s | final error m | tracking error rms / max m '
             '| min obstacle clearance mm | obstacle contacts |',
             '|---|---|---|---|---|---|---|---|']
    for robot, r in results['robots'].items():
        arrival = f"{r['arrival_time']:.1f}" if r['arrival_time'] is not None else '-'
        tracking = (f"{r['tracking_error_rms']:.3f} / {r['tracking_error_max']:.3f}"
                    if r['tracking_error_rms'] is not None else '-')
        clearance = (results.get('obstacle_clearance') or {}).get(robot, {})
        lines.append(f"| {robot} | {r['role_id']} | {'yes' if r['arrived'] else 'NO'} | {arrival} | "
                     f"{r['final_error']:.3f} | {tracking} | {_mm(clearance.get('min_clearance'))} | "
                     f"{clearance.get('contacts', 0)} |")
    if results.get('stopped_player'):
        lines += ['', f"Stopped player: {results['stopped_player']}; rounds: "
                  + '; '.join(f"{r['round']} {r['status']} ({r['message']})" for r in results['rounds'])]
    if acceptance:
        lines += ['', f"Acceptance: {'passed' if acceptance['passed'] else 'FAILED'} ({acceptance['reason']})."]
    return '\n'.join(lines) + '\n'


def _mm(value: float | None) -> str:
    return '-' if value is None else f'{1000.0 * value:.1f} mm'


def plot_commanded_vs_tracked(log: FormationLog, results: dict, path: Path,
                              scene: SceneLayout | None = None) -> None:
    """Fig. 15: commanded (+, the role in force) and actual (., ground truth) positions of every robot in
    its simulation colour, over the scene's walls, obstacles (map cells too) and targets, as the report's
    trajectory plots draw them (``scene``: :func:`collab_tools.experiments.plots.bag_scene`)."""
    fig, (ax, ax_err) = plots.figure(12.0, 5.4, columns=2)
    draw_scene(ax, scene)
    colours = robot_colours(log.truth, scene)
    for robot in sorted(log.truth):
        colour = colours[robot]
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
    frame_scene(ax, scene)
    ax.set_xlabel('x (m)')
    ax.set_ylabel('y (m)')
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=4, loc='upper center', bbox_to_anchor=(0.5, -0.12))   # below the map, off the paths
    ax.set_title('commanded (+, process role in force) vs actual (., ground truth); o: goals', fontsize=9)
    ax_err.set_xlabel('time since the first ground-truth message (s)')
    ax_err.set_ylabel('|commanded - actual| (m)')
    ax_err.set_title('tracking error', fontsize=9)
    ax_err.grid(alpha=0.3)
    ax_err.legend(fontsize=7)
    plots.save(fig, path)


def plot_commands(log: FormationLog, path: Path, scene: SceneLayout | None = None) -> None:
    """The recorded cmd_vel of every robot (linear and angular) over time, in its simulation colour."""
    fig, (ax_v, ax_w) = plots.figure(9.0, 5.4, rows=2, sharex=True)
    t0 = log.truth_times[0] if len(log.truth_times) else 0.0
    colours = robot_colours(log.commands, scene)
    for robot, commands in sorted(log.commands.items()):
        if len(commands) == 0:
            continue
        colour = colours[robot]
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

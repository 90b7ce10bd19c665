"""``coalition-boxpush``: box pushing and navigation with executable coalitions in simulation (IQ-ASyMTRe).

Paper: Section V-A-5, Fig. 10 and Fig. 11 (paper ``iq_asymtre_coalitions``, CITATION.cff), the
cooperative robot box pushing task: five robots of three types; the box-pushing leader forms a
coalition with a teammate whose bumper it needs, the robot that cannot localise forms one with a
GPS robot that sees it, the helpers stream what they committed to and the motor schemas drive.
Each run is config/experiments/coalition_boxpush.yaml (bridge + five schema_agent nodes, recorded)
with the agent channel's loss probability as an override; everything reported is read back from
the bag (:func:`read_run`):

* the coalitions formed (from the agents' /<robot>/coalition status), each leader's time from
  the start of its search to its first coalition, the re-formings and the final states;
* ground truth (/ground_truth/bodies): the box's and the navigating robot's final distances to
  their goals, and every trajectory (the plot);
* the channel traffic (the batch topic, batches unpacked) by message kind;
* conflicts: a robot whose status moves from one coalition to another without being released in
  between held two commitments (the CommitmentLedger forbids it; this checks it from outside;
  :func:`.coalition_bag.conflicting_commitments`).

Inputs (each from the command line, every one validated before anything runs,
:func:`boxpush_inputs`): ``--experiment`` the orchestration file (default
config/experiments/coalition_boxpush.yaml: the bridge and one schema_agent node per robot, with
each robot's task and goal), ``--scenario`` the bridge scenario (default the experiment's: the
robots, the box named ``box``, ``obstacles``), ``--team`` the capability file (default the
experiment's: every agent's ``capability_file``), ``--agents`` the agents' shared parameter file
(default config/coalitions/boxpush_agents.yaml). The team's robots must stand in the scenario with
the sensors their types name (and the same fiducial field of view where the team file gives one),
one leader must push the box and one navigate.

``results.json``: ``runs`` (one per loss probability) with ``coalitions``, ``robots`` (final
state, coalition and detail per robot), ``box`` and ``navigation`` (final ground-truth distance to
the goal, ``completed`` as reported by the leader, ``reached`` = within
:data:`ACCEPTANCE_TOLERANCE_M` of it), ``time_to_form_s`` per leader, ``messages`` by kind,
``conflicts``. Acceptance (``passed``): every run got the box and the navigating robot to their
goals without a conflict. The leaders stop at their own ``goal_tolerance`` (agents' parameters) of
their *estimate*; it is tighter than the acceptance, so that the estimate's error (a few cm)
does not decide the result.
"""
from __future__ import annotations

import math
from pathlib import Path

import yaml
from collab_tools.core.bag_analysis import read_messages
from collab_tools.core.report_plots import draw_scene, frame_scene, robot_colours
from collab_tools.core.scene_layout import SceneLayout
from collab_tools.experiments import plots
from collab_tools.experiments.api import ExperimentRequest, ExperimentResult
from collab_tools.experiments.checkpoint import fresh_step_dir
from collab_tools.orchestration.experiment import run_experiment

from ..core.agent_state import AgentState
from ..core.errors import ConfigError
from .boxpush_inputs import ACCEPTANCE_TOLERANCE_M, BOX, BOX_TASK, NAVIGATION_TASK, agent_nodes, boxpush_inputs
from .coalition_bag import conflicting_commitments, kind_totals, read_coalition_bag

GROUND_TRUTH = '/ground_truth/bodies'
#: The agent channel's loss probabilities, one run each.
LOSSES = (0.0, 0.2)


def read_run(bag: Path, agents: dict[str, dict], goal_tolerance: float) -> dict:
    """Everything the results report about one run, from its bag (see the module docstring)."""
    coalition_run = read_coalition_bag(bag)   # statuses and channel traffic, batches unpacked
    trajectories: dict[str, list[tuple[float, float, float]]] = {}
    for _, _, msg in read_messages(bag, [GROUND_TRUTH]):
        sim_t = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
        for body in msg.bodies:
            if body.name in agents or body.name == BOX:
                trajectories.setdefault(body.name, []).append((sim_t, body.pose.position.x, body.pose.position.y))
    statuses = {robot: coalition_run.of(robot) for robot in agents}
    coalitions: dict[str, dict] = {}
    for robot, history in statuses.items():
        for status in history:
            cid = status.coalition_id
            if cid and status.state is AgentState.COMMITTED and status.leader == robot and cid not in coalitions:
                coalitions[cid] = {'leader': robot, 'members': list(status.members), 'cost': status.cost,
                                   'established_at_s': round(status.stamp, 3)}
    conflicts = [{'robot': robot, 'coalitions': held}
                 for robot, held in conflicting_commitments(coalition_run).items()]
    leaders = {robot: params for robot, params in agents.items() if params.get('task', 'none') != 'none'}
    time_to_form = {}
    for robot in leaders:
        started = next((s.stamp for s in statuses[robot] if s.state is AgentState.SEARCHING), None)
        formed = next((s.stamp for s in statuses[robot] if s.state is AgentState.COMMITTED and s.coalition_id), None)
        time_to_form[robot] = None if started is None or formed is None else round(formed - started, 3)
    final = {robot: history[-1] if history else None for robot, history in statuses.items()}

    def outcome(leader: str, body: str) -> dict:
        goal = [float(v) for v in leaders[leader]['goal_position']]
        path = trajectories.get(body, [])
        if not path:
            return {'leader': leader, 'goal': goal, 'final_distance_m': None, 'completed': False, 'reached': False}
        _, x, y = path[-1]
        distance = math.hypot(goal[0] - x, goal[1] - y)
        last = final[leader]
        return {'leader': leader, 'goal': goal, 'final_position': [round(x, 3), round(y, 3)],
                'final_distance_m': round(distance, 3),
                'completed': last is not None and last.state is AgentState.COMPLETED,
                'reached': distance <= goal_tolerance, 'leader_detail': last.detail if last else ''}

    box_leader = next(r for r, p in leaders.items() if p['task'] == BOX_TASK)
    nav_leader = next(r for r, p in leaders.items() if p['task'] == NAVIGATION_TASK)
    reforms = {robot: sum(1 for a, b in zip(statuses[robot], statuses[robot][1:])
                          if a.state is AgentState.COMMITTED and b.state is AgentState.SEARCHING) for robot in leaders}
    return {
        'coalitions': coalitions,
        'time_to_form_s': time_to_form,
        'reforms': reforms,
        'robots': {robot: ({'state': last.state.label, 'coalition_id': last.coalition_id, 'detail': last.detail}
                           if last else {'state': 'no status', 'coalition_id': '', 'detail': ''})
                   for robot, last in final.items()},
        'box': outcome(box_leader, BOX),
        'navigation': outcome(nav_leader, nav_leader),
        'messages': kind_totals(coalition_run),
        'ros_messages': coalition_run.ros_messages,
        'conflicts': conflicts,
        'trajectories': {name: [[round(v, 3) for v in point] for point in path[::5]]
                         for name, path in trajectories.items()},
    }


def plot_run(run: dict, path: Path, title: str, scene: SceneLayout | None = None) -> None:
    """Every body's ground-truth trajectory over the scene (walls, obstacles, the box where it started),
    as the report's trajectory plots draw it: each robot in its simulation colour, the box's path dashed
    in the box's colour; o start, s end, and the two goals
    (``scene``: :func:`collab_tools.experiments.plots.bag_scene`)."""
    fig, ax = plots.figure(8.5, 7.0)
    draw_scene(ax, scene)
    paths = {name: points for name, points in run['trajectories'].items() if points}
    colours = robot_colours([name for name in paths if name != BOX], scene)
    box_colour = next((b.color for b in (scene.movable_boxes if scene else ()) if b.name == BOX), 'gray')
    for name, points in sorted(paths.items()):
        xs, ys = [p[1] for p in points], [p[2] for p in points]
        if name == BOX:
            ax.plot(xs, ys, '--', color=box_colour, linewidth=2.5, label=f'{name} (pushed)', zorder=3)
            continue
        ax.plot(xs, ys, '-', color=colours[name], linewidth=1.5, label=name, zorder=3)
        ax.plot(xs[0], ys[0], 'o', color=colours[name], markersize=7, zorder=4)
        ax.plot(xs[-1], ys[-1], 's', color=colours[name], markersize=7, markeredgecolor='black', zorder=4)
    for key, marker in (('box', '*'), ('navigation', 'X')):
        goal = run[key]['goal']
        ax.plot(goal[0], goal[1], marker, markersize=16, color='black', label=f'{key} goal', zorder=5)
    ax.plot([], [], 'o', color='gray', label='start')
    ax.plot([], [], 's', color='gray', markeredgecolor='black', label='end')
    frame_scene(ax, scene)
    ax.set_xlabel('x (m)')
    ax.set_ylabel('y (m)')
    ax.set_title(title + ('' if scene else ' (scene unknown)'))
    ax.grid(True, alpha=0.3)
    plots.legend_outside(ax, fontsize=8)
    plots.save(fig, path, dpi=120)


def run(request: ExperimentRequest) -> ExperimentResult:
    """One recorded simulation per loss probability of :data:`LOSSES` (see the module docstring);
    summary.md and each run's trajectories.png (in ``loss_<p>/``) in the run directory."""
    config_dir, run_dir, seed, log = Path(request.config_dir), Path(request.run_dir), request.seed, request.log
    losses = LOSSES
    experiment, agents, goal_tolerance = boxpush_inputs(
        config_dir, request.option('experiment'), request.option('scenario'), request.option('team'),
        request.option('agents'))
    Path(run_dir).mkdir(parents=True, exist_ok=True)
    experiment_path = Path(run_dir) / 'experiment.yaml'
    experiment_path.write_text(yaml.safe_dump(experiment, sort_keys=False))
    quiet = lambda _text: None  # noqa: E731
    def loss_run(index: int, loss: float) -> dict:
        if not 0.0 <= loss <= 1.0:
            raise ConfigError(f'loss: must be in [0, 1] (got {loss!r})')
        label = f'loss_{loss:g}'
        case_dir = fresh_step_dir(run_dir, Path(run_dir) / label)   # an interrupted try set aside
        overrides = {params['node']: {'loss_probability': float(loss), 'seed': seed * 100 + index * 10 + position}
                     for position, params in enumerate(agents.values())}
        log(f'[coalition-boxpush] {label}: running the simulation ({case_dir})')
        result = run_experiment(experiment_path, Path(config_dir), run_dir=case_dir, overrides=overrides, log=quiet)
        if result.bag is None or not result.bag.exists():
            raise RuntimeError(f'{label}: no bag recorded ({result.message}); logs in {case_dir / "logs"}')
        run = read_run(result.bag, agents, ACCEPTANCE_TOLERANCE_M)
        run.update({'loss_probability': loss, 'condition_met': result.condition_met, 'session': result.message})
        plot_run(run, case_dir / 'trajectories.png', f'coalition box pushing and navigation, loss {loss:g}',
                 plots.bag_scene(result.bag))
        log(f"[coalition-boxpush] {label}: box {run['box']['final_distance_m']} m from its goal "
            f"(completed {run['box']['completed']}), navigation {run['navigation']['final_distance_m']} m "
            f"(completed {run['navigation']['completed']}); time to form {run['time_to_form_s']}; "
            f"re-formings {run['reforms']}; conflicts {len(run['conflicts'])}")
        return run

    with request.progress('coalition-boxpush', len(losses)) as steps:   # each loss checkpointed (--resume)
        step = steps.checkpointed(loss_run, key=lambda index, loss: f'loss_{loss:g}',
                                  describe=lambda run: f"box {run['box']['final_distance_m']} m from its goal")
        runs = [step(index, loss) for index, loss in enumerate(losses)]
    results = {'goal_tolerance_m': ACCEPTANCE_TOLERANCE_M, 'leader_goal_tolerance_m': goal_tolerance, 'runs': runs}
    acceptance = {'box_reached': all(r['box']['reached'] for r in runs),
                  'navigation_reached': all(r['navigation']['reached'] for r in runs),
                  'no_conflicts': all(not r['conflicts'] for r in runs)}
    passed = all(acceptance.values())
    table = summary_markdown(results)
    outcome = '; '.join(f"loss {r['loss_probability']:g}: box {r['box']['final_distance_m']} m, navigation "
                        f"{r['navigation']['final_distance_m']} m from the goal, {len(r['conflicts'])} conflicts"
                        for r in runs)
    return ExperimentResult(passed=passed, outcome=outcome, report=table, acceptance=acceptance, data=results,
                            report_file='summary.md')


def summary_markdown(results: dict) -> str:
    lines = ['| loss | coalitions | time to form (s) | re-formings | box to goal (m) | box completed | '
             'navigation to goal (m) | navigation completed | conflicts | messages |',
             '|---|---|---|---|---|---|---|---|---|---|']
    for run in results['runs']:
        coalitions = '; '.join(f"{c['leader']}: {'+'.join(c['members'])} ({c['cost']:g})"
                               for c in run['coalitions'].values())
        lines.append(f"| {run['loss_probability']:g} | {coalitions} | {run['time_to_form_s']} | {run['reforms']} | "
                     f"{run['box']['final_distance_m']} | {run['box']['completed']} | "
                     f"{run['navigation']['final_distance_m']} | {run['navigation']['completed']} | "
                     f"{len(run['conflicts'])} | {sum(run['messages'].values())} |")
    return '\n'.join(lines) + '\n'


__all__ = ['ACCEPTANCE_TOLERANCE_M', 'LOSSES', 'agent_nodes', 'boxpush_inputs', 'plot_run', 'read_run', 'run', 'summary_markdown']

"""``coalition-fig7``: possible vs executable coalitions in three clusters (IQ-ASyMTRe, Fig. 7 / Table V).

Paper: Section V-A-2, Fig. 7 and Table V (paper ``iq_asymtre_coalitions``, CITATION.cff): three
robots that cannot localise and six that can, in three distant clusters; fiducials with a 180 deg
field of view and a 4 m range. Table V counts "coalitions with two robots": *executable* ones are
found with the robots' configuration; *possible* ones are what an approach using only the robot
types of Table IV considers: the same search with every fiducial seeing every robot. Each count is
of distinct member sets, with the cheapest coalition cost of each set.

``--mode core`` (this module, :func:`run_core`): what each fiducial sees comes from the geometric
sensing model (:class:`~..core.geometric_sensing.GeometricSensing`: each robot's field of view
and range, line of sight blocked by the scenario's obstacles and by other robots, as in the bridge;
no noise) over the poses of ``config/coalitions/scenarios/fig7.yaml`` (``--scenario``, ``--team``
replacing its team file), and the team's request/offer exchange runs in one process
(:class:`~..core.CoalitionSearch`).
Acceptance: every initiator's counts and costs match the paper's Table V (``matches_paper``).

``--mode sim`` (:mod:`.fig7_sim`): the same poses with schema_agent nodes on the bridge (``--loss``
on the agent channel), recorded, compared with the core's cheapest coalitions.
"""
from __future__ import annotations

import time
from pathlib import Path
from typing import Callable

from collab_tools.experiments.api import ExperimentRequest, ExperimentResult

from ..core import CoalitionResult, CoalitionSearch, CoalitionSolution, ConfigError
from ..core.geometric_sensing import GeometricSensing
from .configuration import COALITIONS, FIG7_SCENARIO, CoalitionConfig, load_scenario
from .fig7_plots import plot_fig7

Log = Callable[[str], None]

MODES = ('core', 'sim')


def run(request: ExperimentRequest) -> ExperimentResult:
    """The experiment in the mode the request names (core by default)."""
    mode = request.option('mode', 'core')
    if mode not in MODES:
        raise ConfigError(f'--mode: must be one of {", ".join(MODES)} (got {mode!r})')
    if mode == 'sim':
        from .fig7_sim import run_sim
        return run_sim(request)
    return run_core(Path(request.config_dir), Path(request.run_dir), request.log, request.option('scenario'),
                    request.option('team'))


def _two_robot(result: CoalitionResult) -> list[CoalitionSolution]:
    return [c for c in result.per_members() if len(c.members) == 2]


def _coalition_entry(coalition: CoalitionSolution) -> dict:
    return {**coalition.to_dict(), 'local_coalition': list(coalition.local_coalition),
            'description': coalition.describe()}


def load_fig7_scenario(config_dir: Path, scenario_path: str | Path | None = None,
                       team_path: str | Path | None = None):
    """The coalition configuration and the scenario (``--scenario``, default fig7.yaml; ``--team``)."""
    config = CoalitionConfig.load(Path(config_dir) / COALITIONS)
    path = Path(scenario_path) if scenario_path else config.directory / FIG7_SCENARIO
    if not path.is_file():
        raise ConfigError(f'--scenario: no file {str(path)!r}')
    return config, load_scenario(path, config, team_path)


def run_core(config_dir: Path, run_dir: Path, log: Log = print,
             scenario_path: str | Path | None = None, team_path: str | Path | None = None) -> ExperimentResult:
    """Fig. 7 / Table V in the core: table5.md and fig7.png in ``run_dir``; ``config_dir`` is the
    workspace's config/ (the coalition files under coalitions/)."""
    config, scenario = load_fig7_scenario(config_dir, scenario_path, team_path)
    sensing = scenario.sensing()
    sightings = sensing.sightings()
    views = sorted({f'{s} (FOV {v.fov_deg:g} deg, {v.range_m:g} m)'
                    for per_robot in scenario.views().values() for s, v in per_robot.items()})
    log(f'[coalition-fig7] {len(scenario.team)} robots, {len(scenario.obstacles.boxes)} obstacles, '
        f'{len(sightings)} sightings with ' + ', '.join(views))

    def search(model: GeometricSensing, what: str) -> tuple[dict[str, CoalitionResult], dict]:
        begin = time.perf_counter()
        engine = CoalitionSearch(config.library, config.costs, scenario.task, scenario.team, model)
        results = engine.run(scenario.initiators)
        info = {'seconds': round(time.perf_counter() - begin, 3), 'messages': engine.stats.messages,
                'request_deliveries': engine.stats.request_deliveries,
                'offers': sum(engine.stats.offers_sent.values()),
                'solution_spaces': sum(engine.stats.solution_spaces.values())}
        log(f'[coalition-fig7] {what} search: {info["messages"]} messages, {info["solution_spaces"]} solution '
            f'spaces, {info["seconds"]:.2f} s')
        return results, info

    executable, executable_info = search(sensing, 'geometric (executable)')
    blind_model = scenario.sensing(blind=True)
    possible, possible_info = search(blind_model, 'configuration-blind (possible)')

    table5 = []
    chosen = {}
    for robot in scenario.initiators:
        found, blind = executable[robot], possible[robot]
        pairs, possible_pairs = _two_robot(found), _two_robot(blind)
        paper = scenario.paper_table5.get(robot)
        entry = {
            'robot': robot, 'label': scenario.poses[robot].label,
            'possible': len(possible_pairs),
            'possible_partners': [c.members[1] for c in possible_pairs],
            'possible_costs': [c.cost for c in possible_pairs],
            'executable': len(pairs),
            'executable_costs': [c.cost for c in pairs],
            'executable_partners': [c.members[1] for c in pairs],
            'executable_any_size': [{'members': list(c.members), 'cost': c.cost} for c in found.per_members()],
            'instantiations': len(found.coalitions),
            'paper': paper,
        }
        if paper is not None:
            entry['matches_paper'] = (paper['possible'] == entry['possible']
                                      and sorted(paper['executable_costs']) == sorted(entry['executable_costs']))
        table5.append(entry)
        best = found.best
        chosen[robot] = None if best is None else _coalition_entry(best)
        log(f'[coalition-fig7] {robot}: possible {entry["possible"]}, executable {entry["executable"]} '
            f'(costs {", ".join(f"{c:g}" for c in entry["executable_costs"]) or "-"}); chosen: '
            + ('none' if best is None else f'{", ".join(best.members)} at {best.cost:g}'))
    helpers: dict[str, list[str]] = {}
    for robot, coalition in chosen.items():
        for member in (coalition or {}).get('members', [])[1:]:
            helpers.setdefault(member, []).append(robot)
    results = {
        'mode': 'core',
        'note': ('core version (no ROS): fiducial readings from a geometric field-of-view/range model over '
                 'the scenario poses, the team search run in one process; the simulated version comes with '
                 'the schema_agent nodes'),
        'scenario': str(scenario.path),
        'task': scenario.task.name,
        'sensors': {s: {'fov_deg': v.fov_deg, 'range_m': v.range_m} for s, v in scenario.sensors.items()},
        'robots': {robot: {'type': scenario.team[robot].name, 'label': pose.label, 'x': pose.x, 'y': pose.y,
                           'heading_deg': pose.heading_deg} for robot, pose in scenario.poses.items()},
        'sightings': [[a, b] for a, b, _ in sightings],
        'table5': table5,
        'matches_paper': all(e.get('matches_paper', True) for e in table5),
        'chosen': chosen,
        'helpers_shared_by_initiators': {h: r for h, r in helpers.items() if len(r) > 1},
        'search': {'executable': executable_info, 'possible': possible_info},
    }
    own = {robot: {s: {'fov_deg': v.fov_deg, 'range_m': v.range_m} for s, v in per_robot.items()}
           for robot, per_robot in scenario.views().items()
           if any(scenario.team[robot].sensor_view(s) is not None for s in per_robot)}
    if own:  # robots whose team file gives their sensor's own field of view
        results['robot_sensors'] = own
    if scenario.obstacles.boxes:
        results['obstacles'] = [{'name': b.name, 'center': list(b.center), 'size': list(b.size), 'yaw': b.yaw,
                                 'height': b.height, 'occludes': b in scenario.obstacles.occluding}
                                for b in scenario.obstacles.boxes]
    run_dir.mkdir(parents=True, exist_ok=True)
    table = table5_markdown(results)
    plot_fig7(scenario, sensing, results, run_dir / 'fig7.png')
    acceptance = {'matches_paper': results['matches_paper']}
    outcome = (f'{len(table5)} initiators: ' + '; '.join(f'{e["robot"]} possible {e["possible"]}, executable '
                                                         f'{e["executable"]}' for e in table5)
               + f'; paper match: {results["matches_paper"]}')
    log(f'[coalition-fig7] paper match: {results["matches_paper"]}')
    return ExperimentResult(passed=results['matches_paper'], outcome=outcome, report=table, acceptance=acceptance,
                            data=results, report_file='table5.md')


def table5_markdown(results: dict) -> str:
    lines = ['Coalitions with two robots (Table V), core version: geometric visibility, no ROS.', '',
             '| robot | possible coalitions | executable coalitions | paper (possible; executable) | chosen |',
             '|---|---|---|---|---|']
    for entry in results['table5']:
        costs = ', '.join(f'{c:g}' for c in entry['executable_costs'])
        partners = ', '.join(entry['executable_partners'])
        paper = entry['paper']
        paper_text = '-' if paper is None else (f'{paper["possible"]}; {len(paper["executable_costs"])} (cost '
                                                f'{", ".join(f"{c:g}" for c in paper["executable_costs"])})')
        chosen = results['chosen'][entry['robot']]
        chosen_text = 'none' if chosen is None else f'{", ".join(chosen["members"])} ({chosen["cost"]:g})'
        lines.append(f'| {entry["robot"]} ({entry["label"]}) | {entry["possible"]} | {entry["executable"]} '
                     f'(cost {costs or "-"}; with {partners or "-"}) | {paper_text} | {chosen_text} |')
    lines += ['', '## How this is computed', '',
              '- Possible: two-robot coalitions found when every fiducial sees every robot (the configuration '
              'ignored, as approaches that know only the robot types of Table IV do). Executable: found with '
              'the scenario\'s poses, field of view and range. Each is counted once per set of members, with '
              'its cheapest cost.',
              '- Coalition cost (footnote 14): the schemas of every robot in the coalition, a CS pair counted '
              'once, plus the MS each helper runs to keep the relative position (6). With the paper\'s costs '
              'a helper the robot sees gives 16 = Table III row 2 (8) + laser (1) + the helper\'s '
              'localisation (1) + its MS (6); a helper that sees the robot gives 17.5 = row 3 (8.5) + laser (1) '
              '+ localisation (1) + the helper\'s fiducial (1) + its MS (6).',
              '- The paper gives no coordinates: the poses in the scenario file are ours, chosen to have the '
              'properties the text states (distant clusters, R behind one helper and seen by another, G seeing '
              'one helper with helper 5 close but out of range, Y seeing two helpers).',
              '- Visibility is geometric (each robot\'s field of view and range; the line of sight is blocked by '
              'the scenario\'s obstacles taller than the sensor and by other robots\' bodies, the rule the '
              'bridge\'s fiducial applies; no noise) and the team\'s request/offer exchange runs in one process; '
              'the chosen coalition is each robot\'s cheapest executable one (the negotiation that sets it up '
              'belongs to the nodes).',
              '', '## Chosen coalitions', '']
    for robot, chosen in results['chosen'].items():
        lines += ['```', chosen['description'] if chosen else f'{robot}: no executable coalition', '```']
    return '\n'.join(lines) + '\n'


__all__ = ['MODES', 'load_fig7_scenario', 'run', 'run_core', 'table5_markdown']

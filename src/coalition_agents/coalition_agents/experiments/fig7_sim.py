"""``coalition-fig7 --mode sim``: Fig. 7 / Table V with schema_agent nodes on the bridge (IQ-ASyMTRe).

Paper: Section V-A-2, Fig. 7(b) and Table V (paper ``iq_asymtre_coalitions``, CITATION.cff): the
coalitions the robots set up in the three clusters. The core experiment (:func:`.fig7.run_core`:
possible vs executable, geometric sensing) runs first, into ``core/``; then the same poses run in
simulation (``sim/``: the bridge's fiducials with occlusion, each robot's own field of view, the
scenario's obstacles in the generated bridge scenario, ``--loss`` on the agent channel),
recorded; the coalitions the nodes set up are read from the bag and compared with the core's
cheapest executable ones. The agents run on the bridge's clock (the result is not a time).

Acceptance: every initiator the core gives an executable coalition committed to one, none of
the others did (a wall the core sees is a wall in the bridge), and no robot held conflicting
coalitions at once (sharing is allowed; ``matches_core`` is reported beside it).
"""
from __future__ import annotations

import json
import time
from dataclasses import replace
from pathlib import Path
from typing import Mapping

import yaml
from collab_tools.experiments.api import ExperimentRequest, ExperimentResult, write_results

from ..core.errors import ConfigError
from ..core.sim_scenarios import SensorSettings, placements_from_poses
from .coalition_bag import CoalitionRun, commitment_check, commitments, kind_totals, leader_timeline
from .coalition_bag import read_coalition_bag
from .fig7_plots import plot_fig7_sim
from .sessions import AgentSetup, check_session_inputs, run_session

#: The paper's sensor names in the Fig. 7 team file -> the bridge's.
FIG7_SENSOR_NAMES = {'localization': 'gps'}
#: How long (s, simulated) each initiator searches before it negotiates.
SEARCH_TIME_S = 6.0


def fig7_sim_result(run: CoalitionRun, core: Mapping[str, dict]) -> dict:
    """Per initiator: what the nodes set up (from the bag) next to the core's cheapest coalition."""
    rows = []
    for robot in sorted(core):
        timeline = leader_timeline(run, robot)
        expected = core[robot]
        rows.append({**timeline.to_dict(), 'core_members': expected and expected['members'],
                     'core_cost': expected and expected['cost'],
                     'matches_core': (timeline.state != 'committed') if expected is None else (
                         timeline.state == 'committed' and sorted(timeline.members) == sorted(expected['members'])
                         and timeline.cost is not None and abs(timeline.cost - expected['cost']) < 1e-6)})
    check = commitment_check(run)  # sharing (one reading, one value to several leaders) is not a conflict
    return {'leaders': rows, 'commitments': commitments(run), 'conflicting_commitments': check['conflicting'],
            'shared_commitments': check['shared'], 'robots_serving_several': check['robots_serving_several'],
            'messages': len(run.messages), 'ros_messages': run.ros_messages, 'kinds': kind_totals(run)}


def run_sim(request: ExperimentRequest) -> ExperimentResult:
    """Fig. 7 / Table V in simulation (see the module docstring); table5_sim.md and fig7_sim.png in
    the run directory, the core run (with its own results.json) in ``core/``, the session in ``sim/``."""
    from .fig7 import load_fig7_scenario, run_core
    config_dir, run_dir, log = Path(request.config_dir), Path(request.run_dir), request.log
    loss = float(request.option('loss', 0.0))
    if not 0.0 <= loss <= 1.0:
        raise ConfigError(f'--loss: must be in [0, 1] (got {loss})')
    scenario_path, team_path = request.option('scenario'), request.option('team')
    search_time_s = SEARCH_TIME_S
    # Every input is validated before anything runs (the core run below reads the same files).
    _, scenario = load_fig7_scenario(config_dir, scenario_path, team_path)
    views = scenario.views()
    # The team file's robot types as data (capability_file renames their sensors for the bridge).
    types = yaml.safe_load(Path(scenario.team_file).read_text())['robot_types']
    robot_types = {robot: caps.name for robot, caps in scenario.team.items()}
    fiducials = {robot: (v['fiducial'].fov_deg, v['fiducial'].range_m) for robot, v in views.items() if 'fiducial' in v}
    placements = placements_from_poses({r: (p.x, p.y, p.heading_deg) for r, p in scenario.poses.items()}, robot_types,
                                       fiducials)
    check_session_inputs(placements, types, FIG7_SENSOR_NAMES, scenario.obstacles.section)
    core_request = replace(request, run_dir=run_dir / 'core', options={**request.options, 'mode': 'core'})
    began = time.monotonic()
    core_result = run_core(config_dir, core_request.run_dir, log, scenario_path, team_path)
    _write_core_results(core_request, core_result, time.monotonic() - began)
    core = core_result.data
    sensors = SensorSettings()  # every fiducial has its own view (above)
    setup = AgentSetup(task=scenario.task.name, leaders=scenario.initiators, search_time_s=search_time_s,
                       loss_probability=loss, use_sim_time=True, seed=request.seed, timeout_s=240.0)
    log(f'[coalition-fig7 sim] {len(placements)} robots on the bridge, loss {loss:g}, search_time {search_time_s:g} s')
    result = run_session(run_dir / 'sim', config_dir, 'fig7_clusters', placements, types, sensors, setup,
                         sensor_names=FIG7_SENSOR_NAMES, log=None, obstacles=scenario.obstacles.section)
    if result.bag is None or not result.bag.exists():
        raise RuntimeError(f'fig7 sim: no bag ({result.message}); logs in {run_dir / "sim" / "logs"}')
    sim = fig7_sim_result(read_coalition_bag(result.bag), core['chosen'])
    results = {'mode': 'sim', 'loss_probability': loss, 'search_time_s': search_time_s,
               'exit_code': result.exit_code, 'table5_core': core['table5'], 'core_chosen': core['chosen'], **sim}
    acceptance = {
        # an initiator the core gives no executable coalition (a wall in between) must not form one
        'every_initiator_committed': all(r['state'] == 'committed' for r in sim['leaders'] if r['core_members']),
        'none_without_core_coalition': all(r['state'] != 'committed' for r in sim['leaders']
                                           if not r['core_members']),
        'matches_core': all(r['matches_core'] for r in sim['leaders']),
        'no_conflicting_commitments': not sim['conflicting_commitments']}
    # matches_core is reported, not required: the bridge's occlusion may rule out a core coalition.
    passed = (acceptance['every_initiator_committed'] and acceptance['none_without_core_coalition']
              and acceptance['no_conflicting_commitments'])
    for row in sim['leaders']:
        log(f'[coalition-fig7 sim] {row["robot"]}: {row["state"]} {", ".join(row["members"]) or "-"} cost '
            f'{row["cost"]} (core: {row["core_members"] and ", ".join(row["core_members"])} {row["core_cost"]}); '
            f'found {row["found_s"]} s, formed {row["formed_s"]} s')
    table = fig7_sim_markdown(results, {**acceptance, 'passed': passed})
    plot_fig7_sim(scenario, results, run_dir / 'fig7_sim.png')
    outcome = '; '.join(f'{r["robot"]}: {r["state"]} {"+".join(r["members"]) or "-"} (cost {r["cost"]})'
                        for r in sim['leaders'])
    return ExperimentResult(passed=passed, outcome=outcome, report=table, acceptance=acceptance, data=results,
                            report_file='table5_sim.md')


def _write_core_results(request: ExperimentRequest, result: ExperimentResult, wall_s: float) -> None:
    """The core part's results.json in ``core/`` (as a ``--mode core`` run would write it)."""
    from . import experiment_named
    write_results(experiment_named('coalition-fig7'), request, result, wall_s)


def fig7_sim_markdown(results: dict, acceptance: dict) -> str:
    lines = [f'Fig. 7 / Table V in simulation (schema_agent nodes, bridge fiducials, link paper_fig9, loss '
             f'{results["loss_probability"]:g}).', '',
             '| robot | possible (core) | executable (core, costs) | set up in simulation | cost | core cheapest | '
             'matches core | found (s) | formed (s) |', '|---|---|---|---|---|---|---|---|---|']
    table5 = {e['robot']: e for e in results['table5_core']}
    for row in results['leaders']:
        entry = table5.get(row['robot'], {})
        costs = ', '.join(f'{c:g}' for c in entry.get('executable_costs', []))
        lines.append(f'| {row["robot"]} | {entry.get("possible")} | {entry.get("executable")} ({costs or "-"}) | '
                     f'{", ".join(row["members"]) or row["state"]} | {row["cost"]} | '
                     f'{", ".join(row["core_members"] or [])} ({row["core_cost"]}) | {row["matches_core"]} | '
                     f'{row["found_s"]} | {row["formed_s"]} |')
    lines += ['', f'Commitments per robot (from the bag\'s statuses): {json.dumps(results["commitments"])}',
              f'Robots serving several coalitions at once (sharing): {json.dumps(results.get("shared_commitments", {}))} '
              f'({results.get("robots_serving_several", 0)} robot(s)); conflicting commitments: '
              f'{json.dumps(results["conflicting_commitments"]) or "none"}',
              f'Channel messages: {results["messages"]} logical ({json.dumps(results["kinds"])}) in '
              f'{results.get("ros_messages", 0)} ROS messages (batches; the loss probability applies per batch: '
              'a lost batch loses all its messages, which the retries re-send)',
              f'Acceptance: {json.dumps(acceptance)}']
    return '\n'.join(lines) + '\n'



__all__ = ['FIG7_SENSOR_NAMES', 'fig7_sim_markdown', 'fig7_sim_result', 'run_sim']

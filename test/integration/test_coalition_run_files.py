"""A simulated coalition run whose agents read no file of the run directory (issue 11, item 5):
the column demo (3 robots, one schema_agent_host) gets the team as its agents' ``capabilities``
parameter and their parameters as a parameter-file mapping in the experiment, so an agent host
on another machine needs only the repository's tracked config. Only the bridge (on the
orchestrator's machine) reads a generated file, its scenario."""

import json

import yaml

from coalition_agents.experiments.column import run_column_demo


def run_dir_paths(value, run_dir) -> list[str]:
    """Every string in ``value`` (nested) that names something in the run directory."""
    if isinstance(value, dict):
        return [p for item in value.values() for p in run_dir_paths(item, run_dir)]
    if isinstance(value, list):
        return [p for item in value for p in run_dir_paths(item, run_dir)]
    return [value] if isinstance(value, str) and ('{run_dir}' in value or str(run_dir) in value) else []


def test_column_demo_agents_read_no_run_directory_file(config_dir, tmp_path):
    run_dir = (tmp_path / 'demo').resolve()
    result = run_column_demo(config_dir, run_dir, robots=3, log=print)
    assert result.exit_code == 0, result.message

    experiment = yaml.safe_load((run_dir / 'experiment.yaml').read_text())
    readers = {}
    for node in experiment['nodes']:
        readers[node['executable']] = run_dir_paths(node.get('parameters', []), run_dir)
    assert readers.pop('pybullet_bridge') == ['{run_dir}/scenario.yaml']
    assert readers == {'schema_agent_host': []}, readers
    assert not (run_dir / 'agents.yaml').exists()
    # What the host's process was given: its parameter files, the agents' among them (team inline).
    session = json.loads((run_dir / 'session.json').read_text())
    command = session['nodes']['schema_agent_host']['command']
    files = [command[i + 1] for i, token in enumerate(command) if token == '--params-file']
    contents = [yaml.safe_load(open(path)) for path in files]
    agents = next(c for c in contents if '/**/robot_3/schema_agent' in c)
    assert 'robot_types' in agents['/**']['ros__parameters']['capabilities']
    assert not any('team.yaml' in open(path).read() for path in files)

    summary = json.loads((run_dir / 'coalition.json').read_text())
    assert summary['state'] == 'committed', summary
    assert summary['leader'] == 'robot_3' and sorted(summary['members']) == ['robot_1', 'robot_2', 'robot_3'], summary


def test_a_wall_rules_out_in_simulation_the_coalition_it_rules_out_in_the_core(config_dir, tmp_path):
    """Issue 13, item 2: the red cluster of config/coalitions/scenarios/walls.yaml on the bridge.
    R would see helper_1 (cost 16) but a wall stands between them; helper_2 sees R past a wall
    beside its line of sight. The core's executable coalition (R + helper_2, 17.5) is the one the
    schema_agent nodes set up on the generated bridge scenario (same walls, same FOV rule)."""
    from collab_tools.experiments.api import ExperimentRequest
    from coalition_agents.experiments import fig7

    data = yaml.safe_load((config_dir / 'coalitions' / 'scenarios' / 'walls.yaml').read_text())
    data['team'] = str(config_dir / 'coalitions' / 'capabilities' / 'walls_team.yaml')
    team = yaml.safe_load(open(data['team']).read())
    red = ('robot_red', 'helper_1', 'helper_2')
    team['robots'] = {robot: team['robots'][robot] for robot in red}
    (tmp_path / 'team.yaml').write_text(yaml.safe_dump(team))
    data.update(team=str(tmp_path / 'team.yaml'), initiators=['robot_red'],
                robots={robot: data['robots'][robot] for robot in red}, goals={})
    data['obstacles']['boxes'] = [b for b in data['obstacles']['boxes'] if b['name'] != 'kerb_green']
    path = tmp_path / 'red_walls.yaml'
    path.write_text(yaml.safe_dump(data))
    run_dir = (tmp_path / 'run').resolve()
    result = fig7.run(ExperimentRequest(config_dir, run_dir, options={'mode': 'sim', 'scenario': str(path)}, log=print))
    core = result.data['core_chosen']['robot_red']
    assert core['members'] == ['robot_red', 'helper_2'] and core['cost'] == 17.5
    scenario = yaml.safe_load((run_dir / 'sim' / 'scenario.yaml').read_text())
    assert [b['name'] for b in scenario['obstacles']['boxes']] == ['wall_red', 'wall_beside']
    (leader,) = result.data['leaders']
    assert leader['state'] == 'committed', leader
    assert sorted(leader['members']) == ['helper_2', 'robot_red'] and leader['cost'] == 17.5, leader
    assert leader['matches_core'] and result.passed, result.acceptance

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

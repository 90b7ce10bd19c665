"""Every coalition command takes its inputs from the command line (issue 13, item 5): the options
exist, and a bad input is refused naming the file and field before anything runs."""
from pathlib import Path

import pytest
import yaml

from collab_tools.experiments.api import ExperimentRequest
from coalition_agents.core import ConfigError
from coalition_agents.experiments import experiment_named
from coalition_agents.experiments.boxpush_inputs import boxpush_inputs


def flags(name):
    return {option.flag for option in experiment_named(name).options}


def test_the_coalition_commands_have_their_input_options():
    assert {'--scenario', '--team'} <= flags('coalition-fig7')
    assert {'--column', '--robots'} <= flags('coalition-fig9')
    assert flags('coalition-boxpush') == {'--experiment', '--scenario', '--team', '--agents'}


def test_the_shipped_box_pushing_inputs_fit_together(config_dir):
    experiment, agents, tolerance = boxpush_inputs(config_dir.parent)
    assert sorted(agents) == ['localizer_l1', 'localizer_l2', 'pusher_g1', 'pusher_r1', 'pusher_r2']
    assert experiment['until'] == {'exit': agents['pusher_g1']['node']}
    assert tolerance == 0.25


def copy_inputs(tmp_path: Path, config_dir: Path, team=None, scenario=None, agents=None) -> dict:
    """Edited copies of the shipped box-pushing files (``team``/``scenario``/``agents`` edit the data)."""
    paths = {}
    for key, source, edit in (('team', config_dir / 'capabilities' / 'box_pushing_team.yaml', team),
                              ('scenario', config_dir.parent / 'scenarios' / 'coalition_boxpush.yaml', scenario),
                              ('agents', config_dir / 'boxpush_agents.yaml', agents)):
        data = yaml.safe_load(source.read_text())
        if edit:
            edit(data)
        paths[key] = tmp_path / f'{key}.yaml'
        paths[key].write_text(yaml.safe_dump(data, sort_keys=False))
    return paths


def test_given_files_replace_the_experiments_own(config_dir, tmp_path):
    def wall(data):
        data['obstacles'] = {'boxes': [{'name': 'wall', 'center': [3.0, 0.0], 'size': [0.2, 2.0], 'height': 0.5}]}
    paths = copy_inputs(tmp_path, config_dir, scenario=wall)
    experiment, agents, _ = boxpush_inputs(config_dir.parent, scenario=str(paths['scenario']),
                                           team=str(paths['team']), agents_file=str(paths['agents']))
    bridge = next(n for n in experiment['nodes'] if n['executable'] == 'pybullet_bridge')
    assert any(isinstance(e, dict) and e.get('scenario') == str(paths['scenario'].resolve())
               for e in bridge['parameters'])
    assert {a['capability_file'] for a in agents.values()} == {str(paths['team'].resolve())}
    agent_nodes = [n for n in experiment['nodes'] if n['executable'] == 'schema_agent']
    assert all(n['parameters'][0] == str(paths['agents'].resolve()) for n in agent_nodes)


def _no_bumper(data):
    data['mobile_robots'][1]['sensors'].pop('bumper')


def _narrow_team(data):
    data['robot_types']['L']['sensors'][1].update(fov_deg=90.0, range_m=4.0)


@pytest.mark.parametrize('edits, message', [
    ({'team': lambda d: d['robots'].pop('pusher_r1')}, r"team\.yaml: robots: no robot 'pusher_r1'"),
    ({'scenario': _no_bumper}, r"scenario\.yaml: mobile_robots\.pusher_r1\.sensors: no bumper \(its type 'R'"),
    ({'scenario': lambda d: d['movable_boxes'][0].update(name='crate')}, r"movable_boxes: no box named 'box'"),
    ({'scenario': lambda d: d['mobile_robots'].pop(4)}, r"mobile_robots: no robot 'localizer_l2'"),
    ({'scenario': lambda d: d.update(obstacles={'boxes': [{'center': [0, 0]}]})},
     r'--scenario: .*obstacles\.boxes\[0\]\.size: missing required field'),
    ({'team': _narrow_team}, r"mobile_robots\.localizer_l1\.sensors\.fiducial: fov_deg 180, range 4 differ from its "
                             r"type 'L' in team\.yaml \(90 deg, 4 m\)"),
    ({'agents': lambda d: d['/**']['ros__parameters'].update(goal_tolerance=0.5)},
     r'agents\.yaml: /\*\*\.ros__parameters\.goal_tolerance: the leaders must stop within'),
    ({'agents': lambda d: d['/**']['ros__parameters'].pop('goal_tolerance')},
     r'agents\.yaml: /\*\*\.ros__parameters\.goal_tolerance: must be a number'),
])
def test_box_pushing_inputs_that_do_not_fit_are_refused(config_dir, tmp_path, edits, message):
    paths = copy_inputs(tmp_path, config_dir, **edits)
    with pytest.raises(ConfigError, match=message):
        boxpush_inputs(config_dir.parent, scenario=str(paths['scenario']), team=str(paths['team']),
                       agents_file=str(paths['agents']))


def test_box_pushing_experiment_errors(config_dir, tmp_path):
    with pytest.raises(ConfigError, match=r"--team: no file 'nowhere\.yaml'"):
        boxpush_inputs(config_dir.parent, team='nowhere.yaml')
    experiment = yaml.safe_load((config_dir.parent / 'experiments' / 'coalition_boxpush.yaml').read_text())
    experiment['nodes'][2]['parameters'][1]['task'] = 'box_pushing_to_goal'      # two box pushers, no navigation
    path = tmp_path / 'experiment.yaml'
    path.write_text(yaml.safe_dump(experiment).replace('{config}', str(config_dir.parent)))
    with pytest.raises(ConfigError, match=r'exactly one schema_agent must run task box_pushing_to_goal \(got 2\)'):
        boxpush_inputs(config_dir.parent, experiment_path=str(path))
    experiment['nodes'][2]['parameters'][1].update(task='navigation', goal_position=[1.0])
    path.write_text(yaml.safe_dump(experiment))
    with pytest.raises(ConfigError, match=r'/pusher_r2/schema_agent goal_position: must be \[x, y\]'):
        boxpush_inputs(config_dir.parent, experiment_path=str(path))


def test_fig7_and_fig9_refuse_missing_files_before_running(config_dir, tmp_path):
    from coalition_agents.experiments import fig7, fig9
    request = ExperimentRequest(config_dir.parent, tmp_path, options={'scenario': str(tmp_path / 'none.yaml')})
    with pytest.raises(ConfigError, match=r"--scenario: no file '.*none\.yaml'"):
        fig7.run(request)
    request = ExperimentRequest(config_dir.parent, tmp_path, options={'mode': 'sim', 'team': 'none.yaml'})
    with pytest.raises(ConfigError, match=r"--team: no file 'none\.yaml'"):
        fig7.run(request)
    with pytest.raises(ConfigError, match=r"--column: no file 'none\.yaml'"):
        fig9.run(ExperimentRequest(config_dir.parent, tmp_path, options={'column': 'none.yaml'}))
    with pytest.raises(ConfigError, match=r'--robots: column sizes must be integers >= 2 \(got 1\)'):
        fig9.run(ExperimentRequest(config_dir.parent, tmp_path, options={'robots': [3, 1]}))
    assert not list(tmp_path.iterdir())


def test_a_walls_scenario_in_sim_mode_is_checked_by_the_bridge_parser_first(config_dir, tmp_path):
    data = yaml.safe_load((config_dir / 'scenarios' / 'walls.yaml').read_text())
    data['team'] = str(config_dir / 'capabilities' / 'walls_team.yaml')
    data['obstacles']['boxes'][0]['color'] = [2.0, 0.0, 0.0]
    path = tmp_path / 'walls.yaml'
    path.write_text(yaml.safe_dump(data))
    from coalition_agents.experiments import fig7
    request = ExperimentRequest(config_dir.parent, tmp_path / 'run', options={'mode': 'sim', 'scenario': str(path)})
    with pytest.raises(ConfigError, match=r'obstacles\.boxes\[0\]\.color'):
        fig7.run(request)
    assert not (tmp_path / 'run').exists()

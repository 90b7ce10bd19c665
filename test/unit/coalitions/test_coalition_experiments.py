"""The core-level coalition experiments (Table III, Fig. 7 / Table V) and the generation benchmark."""
import json

import pytest
import yaml

from collab_tools.experiments.api import ExperimentRequest, run_experiment
from coalition_agents.experiments.benchmark import referent_library, run_benchmark
from coalition_agents.core import ConfigError
from coalition_agents.core.geometric_sensing import FieldOfView, GeometricSensing, Pose
from coalition_agents.experiments import experiment_named
from coalition_agents.experiments.configuration import CoalitionConfig, load_scenario

PAPER_TABLE3_COSTS = [5.0, 8.0, 8.5, 9.0, 9.5, 10.5, 11.0, 11.5, 11.5, 12.0, 12.0]


def quiet(_line):
    pass


def run_named(name, config_dir, run_dir, log=quiet, **options):
    """Run an experiment as scripts/experiment does (results.json written); ``config_dir`` is
    config/coalitions, the request takes the workspace's config/."""
    request = ExperimentRequest(config_dir=config_dir.parent, run_dir=run_dir, options=options, log=log)
    return run_experiment(experiment_named(name), request)


# --- Table III ---------------------------------------------------------------------------------

def test_table3_experiment(config_dir, tmp_path):
    lines = []
    result = run_named('coalition-table3', config_dir, tmp_path, log=lines.append)
    results = result.data
    assert result.passed and result.acceptance['costs_match_paper'] and result.acceptance['leaves_match_paper']
    assert [s['cost'] for s in results['solutions'][:4]] == [5.0, 8.0, 8.5, 9.0]
    assert results['costs'] == PAPER_TABLE3_COSTS and results['matches_paper']
    assert all(s['leaves_match_paper'] for s in results['solutions'])
    # Rows 5, 8, 10, 11 need the information of a cheaper row (Section V-A-1's post-processing).
    assert results['dominated_ranks'] == [5, 8, 10, 11]
    assert [s['dominated_by'] for s in results['solutions'] if not s['kept']] == [3, 7, 7, 7]
    assert results['kept_costs'] == [5.0, 8.0, 8.5, 9.0, 10.5, 11.0, 11.5]
    assert results['solutions'][1]['schemas'] == [
        'MS navigate',
        'RPS global_from_relative: F_G(X) + F_R(local, X) => F_G(local)',
        'CS: F_G(X)',
        'RPS relative_inverse: F_R(X, local) => F_R(local, X)',
        'EPS fiducial: F_R(X, local)',
    ]
    assert results['solutions'][1]['paper_printed'] == 'CS: F_G(X), EPS: F_G(X, local)'   # the F_G typo
    # The 'outputs' reading of Generality Imposition adds two solutions Table III does not list.
    assert [e['cost'] for e in results['generality_outputs_reading']['extra']] == [14.0, 14.0]
    assert results['full_task']['costs'] == [c + 1.0 for c in PAPER_TABLE3_COSTS]   # + laser
    assert results['space'] == {'stored_nodes': 35, 'tree_schema_nodes': 24, 'potential_solutions': 11}

    stored = json.loads((tmp_path / 'results.json').read_text())
    assert {'solutions', 'costs', 'paper_costs', 'kept_costs', 'dominated_ranks', 'wall_s'} <= set(stored)
    assert all({'schemas', 'cost', 'paper_cost', 'kept'} <= set(s) for s in stored['solutions'])
    costs = [s['cost'] for s in stored['solutions']]
    assert costs == sorted(costs)
    table = (tmp_path / 'table3.md').read_text()
    assert '| 5 | 9.5 | 5 (9.5) |' in table and 'dominated by 3' in table
    notes = (tmp_path / 'notes.md').read_text()
    assert 'F_R(X, local)' in notes and "'outputs' reading gives 13" in notes
    assert (tmp_path / 'solution_space.png').stat().st_size > 10_000
    assert any('dominated by 7' in line for line in lines)


# --- Fig. 7 / Table V (core) -------------------------------------------------------------------

@pytest.fixture(scope='module')
def fig7(tmp_path_factory, config_dir):
    run_dir = tmp_path_factory.mktemp('fig7')
    result = run_named('coalition-fig7', config_dir, run_dir)
    assert result.passed == result.data['matches_paper']
    return result.data, run_dir


def test_fig7_table5(fig7):
    results, run_dir = fig7
    table = {entry['robot']: entry for entry in results['table5']}
    assert {robot: entry['possible'] for robot, entry in table.items()} == {
        'robot_red': 6, 'robot_green': 6, 'robot_yellow': 6}
    assert table['robot_red']['executable_costs'] == [16.0, 17.5]
    assert table['robot_red']['executable_partners'] == ['helper_1', 'helper_2']
    assert table['robot_green']['executable_costs'] == [16.0]
    assert table['robot_yellow']['executable_costs'] == [16.0, 16.0]
    assert results['matches_paper']
    # The configuration decides: helper_5 faces G but is out of range, so G has one coalition.
    assert ['helper_5', 'robot_green'] not in results['sightings']
    assert ['robot_red', 'helper_1'] in results['sightings'] and ['helper_2', 'robot_red'] in results['sightings']
    red = results['chosen']['robot_red']
    assert (red['members'], red['cost']) == (['robot_red', 'helper_1'], 16.0)   # red robot in the back
    assert results['helpers_shared_by_initiators'] == {}
    stored = json.loads((run_dir / 'results.json').read_text())
    assert stored['mode'] == 'core' and 'no ROS' in stored['note']
    assert '| robot_red (R) | 6 | 2 (cost 16, 17.5' in (run_dir / 'table5.md').read_text()
    assert (run_dir / 'fig7.png').stat().st_size > 20_000


def test_geometric_sensing_field_of_view_and_range(library, fig7_types):
    team = {'robot_a': fig7_types['type1'], 'robot_b': fig7_types['type2'], 'robot_c': fig7_types['type2'],
            'robot_d': fig7_types['type2'], 'robot_e': fig7_types['type2']}
    poses = {'robot_a': Pose(0.0, 0.0, 0.0, 'A'),
             'robot_b': Pose(3.0, 0.0, 180.0, 'B'),     # ahead, facing A: they see each other
             'robot_c': Pose(0.0, 3.9, 0.0, 'C'),       # exactly at A's FOV edge (90 deg): seen
             'robot_d': Pose(-1.0, 0.0, 0.0, 'D'),      # behind A
             'robot_e': Pose(4.1, 0.0, 0.0, 'E')}       # beyond the 4 m range
    sensing = GeometricSensing(team, poses, {'fiducial': FieldOfView(180.0, 4.0)})
    assert sorted(str(i) for i in sensing.readings('robot_a', 'fiducial')) == [
        'F_R(robot_b, robot_a)', 'F_R(robot_c, robot_a)']
    assert [str(i) for i in sensing.readings('robot_b', 'fiducial')] == [
        'F_R(robot_a, robot_b)', 'F_R(robot_d, robot_b)']
    assert [str(i) for i in sensing.readings('robot_a', 'laser')] == ['F_A(robot_a)']
    assert [str(i) for i in sensing.readings('robot_b', 'localization')] == ['F_G(robot_b)']
    assert sensing.readings('robot_a', 'localization') == ()
    narrow = GeometricSensing(team, poses, {'fiducial': FieldOfView(60.0, 4.0)})
    assert [str(i) for i in narrow.readings('robot_a', 'fiducial')] == ['F_R(robot_b, robot_a)']
    with pytest.raises(ConfigError, match='sensors.fiducial: missing field of view'):
        GeometricSensing(team, poses, {})


def _scenario(tmp_path, config_dir, edit):
    data = yaml.safe_load((config_dir / 'scenarios' / 'fig7.yaml').read_text())
    edit(data)
    path = tmp_path / 'scenario.yaml'
    path.write_text(yaml.safe_dump(data))
    return load_scenario(path, CoalitionConfig.load(config_dir))


@pytest.mark.parametrize('edit, message', [
    (lambda d: d['sensors']['fiducial'].update(fov_deg=400), r'sensors\.fiducial\.fov_deg: must be in \(0, 360\]'),
    (lambda d: d['sensors']['fiducial'].update(range_m=0), r'sensors\.fiducial\.range_m: must be > 0'),
    (lambda d: d['robots'].pop('helper_3'), r'robots: no pose for helper_3'),
    (lambda d: d['initiators'].append('robot_x'), r"initiators\[3\]: unknown robot 'robot_x'"),
    (lambda d: d['robots']['helper_1'].update(position=[1.0]), r'robots\.helper_1\.position: must be \[x, y\]'),
    (lambda d: d.update(task='flying'), r"task: unknown task 'flying'"),
    (lambda d: d.pop('sensors'), r'sensors\.fiducial: missing field of view'),
    (lambda d: d.update(colour='red'), r'colour: unknown field'),
    (lambda d: d['paper_table5']['robot_red'].update(possible=6.5),
     r'paper_table5\.robot_red\.possible: must be a whole number'),
])
def test_scenario_errors_name_the_field(tmp_path, config_dir, edit, message):
    with pytest.raises(ConfigError, match=message):
        _scenario(tmp_path, config_dir, edit)


def test_scenario_file_is_the_fig7_team(config_dir):
    scenario = load_scenario(config_dir / 'scenarios' / 'fig7.yaml', CoalitionConfig.load(config_dir))
    assert len(scenario.team) == 9 and scenario.initiators == ('robot_red', 'robot_green', 'robot_yellow')
    assert scenario.sensors == {'fiducial': FieldOfView(180.0, 4.0)}


# --- Benchmark ---------------------------------------------------------------------------------

def test_referent_library_with_two_referents_is_table1(library):
    generalised, robot = referent_library(2)
    assert [c.text() for c in generalised.reductions] == [c.text() for c in library.reductions[:3]]
    assert [s.describe() for s in robot.sensors] == ['EPS gps: F_G(local)', 'EPS fiducial: F_R(X, local)']
    three, _ = referent_library(3)
    assert three.reductions[-1].text() == 'F_R(Y, V3, X) => F_R(X, Y, V3)'


def test_benchmark_quick(config_dir, tmp_path):
    lines = []
    results = run_benchmark(config_dir, tmp_path, log=lines.append, referents=(1, 2, 3), robots=(2, 5), repeats=1)
    by_referents = {row['referents']: row for row in results['referents']}
    assert by_referents[2]['potential_solutions'] == 11 and by_referents[2]['stored_nodes'] == 35   # Table III
    assert by_referents[2]['first_costs'] == [5.0, 8.0, 8.5, 9.0, 10.5, 11.0, 11.5]
    sizes = [by_referents[n]['potential_solutions'] for n in (1, 2, 3)]
    assert sizes[0] == 1 and sizes[0] < sizes[1] < sizes[2]
    assert by_referents[1]['stored_nodes'] < by_referents[2]['stored_nodes'] < by_referents[3]['stored_nodes']
    rows = {(row['layout'], row['robots']): row for row in results['robots']}
    assert rows[('column', 5)]['largest_coalition'] == 5        # Fig. 9: the coalition includes every robot
    assert rows[('clusters', 5)]['coalitions_found'] == 2        # two clusters, one coalition each
    for layout in ('column', 'clusters'):
        assert rows[(layout, 2)]['solution_spaces'] < rows[(layout, 5)]['solution_spaces']
        assert rows[(layout, 5)]['generation_ms'] > 0
    stored = json.loads((tmp_path / 'results.json').read_text())
    assert {'benchmark', 'settings', 'referents', 'robots', 'wall_s'} <= set(stored)
    assert (tmp_path / 'coalition_bench.png').stat().st_size > 10_000
    assert len(lines) == 3 + 2 * 2 and lines[-1].startswith('[bench coalition 7/7] clusters 5 robots')


# --- The experiments' entries ------------------------------------------------------------------

def test_experiments_are_listed_with_their_options():
    from coalition_agents.experiments import EXPERIMENTS
    options = {e.name: [o.flag for o in e.options] for e in EXPERIMENTS}
    assert options == {'coalition-table3': [], 'coalition-fig7': ['--mode', '--loss', '--scenario', '--team'],
                       'coalition-fig9': ['--robots', '--column'],
                       'coalition-boxpush': ['--experiment', '--scenario', '--team', '--agents']}
    assert all('IQ-ASyMTRe' in e.paper and e.runner() for e in EXPERIMENTS)


@pytest.mark.parametrize('options, message', [({'mode': 'sim', 'loss': 1.5}, r'--loss: must be in \[0, 1\]'),
                                              ({'mode': 'fast'}, '--mode: must be one of core, sim')])
def test_fig7_bad_options_are_refused_before_anything_runs(config_dir, tmp_path, options, message):
    with pytest.raises(ConfigError, match=message):
        run_named('coalition-fig7', config_dir, tmp_path / 'run', **options)
    assert not (tmp_path / 'run' / 'results.json').exists()


def test_fig7_sim_runs_the_core_experiment_first_into_core(config_dir, tmp_path, monkeypatch):
    """--mode sim: the core run (its own results.json, mode core) before the session; a session
    without a bag is an error naming its logs."""
    from types import SimpleNamespace

    from collab_tools.experiments.api import load_results
    from coalition_agents.experiments import fig7_sim
    sessions = []

    def no_bag(run_dir, *args, **kwargs):
        sessions.append((run_dir, kwargs['sensor_names']))
        return SimpleNamespace(bag=None, message='no nodes here', exit_code=1)
    monkeypatch.setattr(fig7_sim, 'run_session', no_bag)
    with pytest.raises(RuntimeError, match='fig7 sim: no bag'):
        run_named('coalition-fig7', config_dir, tmp_path, mode='sim', loss=0.2)
    core = load_results(tmp_path / 'core')
    assert core['experiment'] == 'coalition-fig7' and core['options']['mode'] == 'core' and core['passed']
    assert core['table5'][0]['robot'] == 'robot_red' and (tmp_path / 'core' / 'table5.md').exists()
    assert sessions == [(tmp_path / 'sim', {'localization': 'gps'})]
    assert not (tmp_path / 'results.json').exists()

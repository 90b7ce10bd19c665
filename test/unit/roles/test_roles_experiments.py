"""Role engine experiments (Tables III and IV) on a reduced run, their configuration file, the
seeded problems, and the GP planner's initial LM damping that the experiments rely on."""
import itertools
import json
import re
from pathlib import Path

import numpy as np
import pytest
import yaml

from role_engine.core.environment import RobotType, load_map_file
from role_engine.core.errors import RoleEngineError
from role_engine.core.gp_planner import GPPlanner, GPPlannerConfig
from collab_tools.experiments.api import ExperimentRequest, run_experiment
from role_engine.experiments import EXPERIMENTS
from role_engine.experiments.config import load_experiment_config
from role_engine.experiments.problems import _PlacementCheck, draw_problem

from roles_gp_helpers import AnalyticSDF, straight_line

CONFIG_DIR = Path(__file__).resolve().parents[3] / 'config'
CONFIG_FILE = CONFIG_DIR / 'roles' / 'experiments.yaml'
MAPS_DIR = CONFIG_DIR / 'roles' / 'maps'


def run_table(name, run_dir, log=print, **options):
    """The experiment as scripts/experiment runs it; its results.json (schema keys and the table's data)."""
    experiment = next(e for e in EXPERIMENTS if e.name == name)
    run_experiment(experiment, ExperimentRequest(CONFIG_DIR, Path(run_dir), options=options, log=log))
    return json.loads((Path(run_dir) / 'results.json').read_text())


def _brute_force_minimum(q):
    return min(sum(q[a][r] for r, a in enumerate(order)) for order in itertools.permutations(range(len(q))))


@pytest.fixture(scope='module')
def table3(tmp_path_factory):
    run_dir = tmp_path_factory.mktemp('roles-table3')
    lines = []
    # env_4 (maze, 0.1 m walls): a straight line crosses walls, the E-Map goes round them.
    results = run_table('roles-table3', run_dir, log=lines.append, only=['env_4'], sigma_obs=[0.15],
                        problems_per_environment=2)
    return results, run_dir, lines


@pytest.fixture(scope='module')
def table4(tmp_path_factory):
    run_dir = tmp_path_factory.mktemp('roles-table4')
    lines = []
    results = run_table('roles-table4', run_dir, log=lines.append, only=['env_2'], sigma_obs=[0.15],
                        problems_per_environment=2)
    return results, run_dir, lines


def test_table3_reports_both_initialisations(table3):
    results, _, _ = table3
    for init in ('emap', 'straight'):
        for key in ('feasibility', 'error', 'iterations'):
            assert key in results[init], (init, key)
        assert 0.0 <= results[init]['feasibility'] <= 1.0
        assert results[init]['process_roles'] == 2 * 4
        assert results[init]['error'] > 0.0
    assert set(results['per_environment']) == {'env_4'}
    assert [s['sigma_obs'] for s in results['scenarios']] == [0.15]


def test_table3_emap_is_feasible_and_beats_the_straight_line(table3):
    results, _, _ = table3
    assert results['emap']['feasibility'] == 1.0
    assert results['straight']['feasibility'] < results['emap']['feasibility']
    assert results['emap']['error'] < results['straight']['error']
    assert results['acceptance']['passed']


def test_table3_details_are_consistent_with_the_summary(table3):
    results, _, _ = table3
    assert len(results['problems']) == 2
    feasible = {'emap': [], 'straight': []}
    for problem in results['problems']:
        assert len(problem['sources']) == len(problem['destinations']) == 4
        for init, run in problem['runs']['0.15'].items():
            agents = sorted(a for a, _ in run['pairs'])
            roles = sorted(r for _, r in run['pairs'])
            assert agents == roles == [0, 1, 2, 3]           # a one-to-one assignment
            # GRA picked the cheapest assignment of the problem's own Q.
            assert run['total_cost'] == pytest.approx(_brute_force_minimum(run['Q']), rel=1e-12)
            assert run['total_cost'] == pytest.approx(sum(run['q']), rel=1e-12)
            assert all((clearance >= 0.0) == ok for clearance, ok in zip(run['min_clearance_m'], run['feasible']))
            feasible[init].extend(run['feasible'])
    for init, flags in feasible.items():
        assert results[init]['feasibility'] == pytest.approx(sum(flags) / len(flags))


def test_table3_writes_its_outputs_and_progress(table3):
    results, run_dir, lines = table3
    stored = json.loads((run_dir / 'results.json').read_text())
    assert stored['emap']['feasibility'] == results['emap']['feasibility']
    assert stored['schema'] == 'collab-experiment/1' and stored['experiment'] == 'roles-table3'
    assert stored['passed'] is stored['acceptance']['passed'] is True and stored['problem_seed'] == 3
    table = (run_dir / 'table3.md').read_text()
    assert ('| method | feasibility | paper | average error | paper | ours / paper | average converging time '
            '(iterations) | paper |') in table
    assert re.search(r'\| Our method \(E-Map initialisation\) \| 100\.00% \|', table)
    for name in ('table3_examples.png', 'table3_feasibility.png'):
        assert (run_dir / name).read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'
    steps = [line for line in lines if re.match(r'\[roles-table3 \d+/2\] env_4 problem', line)]
    assert [line.split(']')[0] for line in steps] == ['[roles-table3 1/2', '[roles-table3 2/2']


def test_table4_gra_never_costs_more_than_nearest_neighbour(table4):
    results, _, _ = table4
    for method in ('gra', 'nn'):
        for key in ('feasibility', 'cost', 'iterations'):
            assert key in results[method], (method, key)
        assert 0.0 <= results[method]['feasibility'] <= 1.0
    assert results['gra']['cost'] <= results['nn']['cost']
    for problem in results['problems']:
        run = problem['runs']['0.15']
        assert run['gra']['total_cost'] <= run['nn']['total_cost'] + 1e-15
        assert run['gra']['total_cost'] == pytest.approx(_brute_force_minimum(run['Q']), rel=1e-12)
    assert results['cost_comparison']['gra_higher'] == 0


def test_table4_nearest_neighbour_pairs_closest_first(table4):
    results, _, _ = table4
    for problem in results['problems']:
        sources, destinations = np.array(problem['sources']), np.array(problem['destinations'])
        pairs = problem['runs']['0.15']['nn']['pairs']
        # The globally closest robot-destination pair is always one of NN's pairs.
        distances = np.linalg.norm(sources[:, None] - destinations[None], axis=2)
        closest = list(np.unravel_index(np.argmin(distances), distances.shape))
        assert closest in pairs


def test_table4_team_and_outputs(table4):
    results, run_dir, lines = table4
    assert [(g['name'], g['count'], g['radius']) for g in results['robot_groups']] == [('small', 3, 0.02),
                                                                                        ('large', 3, 0.1)]
    for problem in results['problems']:
        assert problem['agent_types'].count('small') == 3 and problem['agent_types'].count('large') == 3
    report = (run_dir / 'table4.md').read_text().splitlines()
    assert report[0].startswith('- **roles-table4: ') and report[2].startswith('# Table IV')   # outcome first
    assert (run_dir / 'table4_assignments.png').read_bytes()[:4] == b'\x89PNG'
    assert sum(1 for line in lines if line.startswith('[roles-table4 ')) == 2


def test_problems_are_seeded_and_placed_where_every_robot_fits():
    config = load_experiment_config(CONFIG_FILE)
    environment = load_map_file(MAPS_DIR / 'env_6.yaml')
    first = draw_problem(environment, 5, 0, config.table4)
    again = draw_problem(environment, 5, 0, config.table4)
    other = draw_problem(environment, 5, 1, config.table4)
    np.testing.assert_array_equal(first.sources, again.sources)
    np.testing.assert_array_equal(first.destinations, again.destinations)
    assert not np.allclose(first.sources, other.sources)
    placement = config.table4.placement
    check = _PlacementCheck(environment, RobotType('large', 0.1), placement)
    for points in (first.sources, first.destinations):
        assert check.valid(points)            # main free region of the large robot, with clearance
        gaps = np.linalg.norm(points[:, None] - points[None], axis=2)[np.triu_indices(len(points), 1)]
        assert gaps.min() >= 2 * 0.1 + placement.spacing
    # Sources lie within source_spread of their centre, the formation within size / 2 of its own.
    travel = np.linalg.norm(first.destinations.mean(axis=0) - first.sources.mean(axis=0))
    assert travel >= placement.min_travel - placement.source_spread - placement.formation_size[1] / 2


def _write_config(tmp_path, edit):
    data = yaml.safe_load(CONFIG_FILE.read_text())
    data['maps_dir'] = str(MAPS_DIR)
    edit(data)
    path = tmp_path / 'experiments.yaml'
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.mark.parametrize('edit, message', [
    (lambda d: d.update(sigma_obs=[0.1, -0.2]), 'sigma_obs[1]: must be > 0.0'),
    (lambda d: d['gp'].update(sigma_obs=0.1), 'gp.sigma_obs: not settable here: it comes from the top-level sigma_obs list'),
    (lambda d: d['gp'].update(qc=0.0), 'gp.qc: must be > 0'),
    (lambda d: d['gp'].update(lambda_initial=-1.0), 'gp.lambda_initial: must be > 0'),
    (lambda d: d.update(environments=['env_1', 'env_9']), 'environments[1]: no map file env_9.yaml'),
    (lambda d: d.update(plot_sigma=0.3), 'plot_sigma: must be one of sigma_obs'),
    (lambda d: d['table3']['placement'].update(formations=['hexagon']), "formations[0]: unknown formation 'hexagon'"),
    (lambda d: d['table4']['robot_groups'][0].update(count=0), 'table4.robot_groups[0].count: must be >= 1'),
    (lambda d: d['benchmark']['problems'][0].update(init='random'), 'benchmark.problems[0].init: must be one of'),
])
def test_bad_configuration_names_the_field(tmp_path, edit, message):
    with pytest.raises(ValueError, match=re.escape(message)):
        load_experiment_config(_write_config(tmp_path, edit))


def test_run_overrides_are_checked(tmp_path):
    with pytest.raises(RoleEngineError, match='environments: must be a non-empty subset'):
        run_table('roles-table3', tmp_path, only=['env_42'])
    with pytest.raises(RoleEngineError, match='problems_per_environment: must be an integer >= 1'):
        run_table('roles-table4', tmp_path, problems_per_environment=0)


def test_benchmark_problems_are_visitable_for_the_benchmark_robot():
    config = load_experiment_config(CONFIG_FILE)
    robot = RobotType('bench', config.benchmark.robot_radius)
    for problem in config.benchmark.problems:
        view = load_map_file(MAPS_DIR / f'{problem.map}.yaml').for_robot(robot)
        assert view.is_visitable(problem.start) and view.is_visitable(problem.goal), problem


def test_initial_damping_is_a_validated_setting_used_by_both_formulations():
    with pytest.raises(ValueError, match=r'GPPlannerConfig\.lambda_initial: must be > 0'):
        GPPlannerConfig(lambda_initial=0.0)
    sdf = AnalyticSDF(circles=[(2.5, 2.5, 0.6)])
    initial = straight_line((0.5, 0.5), (4.5, 4.4), 30, 20.0)

    def first_step(lambda_initial):
        config = GPPlannerConfig(sigma_obs=0.1, epsilon=0.2, lambda_initial=lambda_initial, max_iterations=1)
        return GPPlanner(config, sdf).plan(initial, 20.0).trajectory

    # LM damping shortens the first step: GPMP2's 1000 moves the states far less than gtsam's 1e-5.
    undamped = np.abs(first_step(1e-5) - initial).max()
    damped = np.abs(first_step(1000.0) - initial).max()
    assert 0.0 < damped < 0.1 * undamped
    planner = GPPlanner(GPPlannerConfig(sigma_obs=0.1, epsilon=0.2, lambda_initial=1000.0), sdf)
    vectorised = planner.plan(initial, 20.0)
    graph = planner.plan(initial, 20.0, formulation='gtsam')
    assert vectorised.cost == pytest.approx(graph.cost, rel=1e-6)
    assert vectorised.iterations == graph.iterations
    assert vectorised.collision_free

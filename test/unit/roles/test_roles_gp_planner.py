"""GP planner: both formulations reach the same cost, obstacles and speed limits act, extra
factors and warm starts work, bad input is rejected with the field's name."""
import numpy as np
import pytest

from role_engine.core import gp_vectorised
from role_engine.core.gp_costs import MovingObstacleTerm
from role_engine.core.gp_gtsam import build_graph, values_from_states
from role_engine.core.gp_planner import GPPlanner, GPPlannerConfig

from roles_gp_helpers import AnalyticSDF, straight_line

SDF = AnalyticSDF(circles=[(2.5, 2.5, 0.6), (1.0, 3.8, 0.35)], boxes=[(3.6, 1.2, 0.3, 0.6)])
TOTAL_TIME = 20.0
STATES = 40


def _other_robot_crossing():
    """Another robot's shared process role crossing the line y = 0.3 at (2.5, 0.3) at mid-time."""
    times = np.linspace(0.0, TOTAL_TIME, STATES)
    positions = np.column_stack([np.full(STATES, 2.5), np.linspace(-1.2, 1.8, STATES)])
    return times, positions


PROBLEMS = {
    'diagonal_through_disc': dict(start=(0.5, 0.5), goal=(4.5, 4.4), config={}),
    'interpolated_checks_and_speed_limit': dict(
        start=(0.3, 3.0), goal=(4.6, 1.9), config=dict(obstacle_interpolation=2, max_speed=0.4, robot_radius=0.05)),
    'other_robot_as_moving_obstacle': dict(start=(0.4, 0.3), goal=(4.6, 0.3), config=dict(epsilon=0.15),
                                           moving=True),
}


def _solve_problem(name, formulation):
    problem = PROBLEMS[name]
    config = GPPlannerConfig(**{'sigma_obs': 0.1, 'epsilon': 0.2, **problem['config']})
    planner = GPPlanner(config, SDF)
    extra = []
    if problem.get('moving'):
        times, positions = _other_robot_crossing()
        extra.append(MovingObstacleTerm.from_timed_positions(times, positions, times, combined_radius=0.4,
                                                             epsilon=0.1, sigma=0.05))
    initial = straight_line(problem['start'], problem['goal'], STATES, TOTAL_TIME)
    return planner, initial, extra, planner.plan(initial, TOTAL_TIME, extra_terms=extra, formulation=formulation)


@pytest.mark.parametrize('name', sorted(PROBLEMS))
def test_both_formulations_reach_the_same_cost(name):
    *_, vectorised = _solve_problem(name, 'vectorised')
    *_, graph = _solve_problem(name, 'gtsam')
    assert vectorised.initial_cost == pytest.approx(graph.initial_cost, rel=1e-12)
    assert vectorised.cost < 1e-2 * vectorised.initial_cost
    # Same LM rules on the same cost: equal to rounding (rtol 1e-6 leaves room for the
    # different linear solvers; observed differences are ~1e-12).
    assert vectorised.cost == pytest.approx(graph.cost, rel=1e-6)
    assert vectorised.iterations == graph.iterations
    np.testing.assert_allclose(vectorised.trajectory, graph.trajectory, atol=1e-6)
    assert vectorised.converged and graph.converged
    for term, cost in vectorised.term_costs.items():
        assert cost == pytest.approx(graph.term_costs[term], rel=1e-5, abs=1e-9), term


def test_result_cost_is_the_graph_error_and_the_sum_of_term_costs():
    planner, initial, extra, result = _solve_problem('interpolated_checks_and_speed_limit', 'vectorised')
    assert result.cost == pytest.approx(sum(result.term_costs.values()), rel=1e-12)
    assert result.initial_cost == pytest.approx(sum(planner.evaluate(initial, TOTAL_TIME).values()), rel=1e-12)
    terms = planner.terms(STATES, TOTAL_TIME, initial[0], initial[-1], extra)
    assert build_graph(terms).error(values_from_states(result.trajectory)) == pytest.approx(result.cost, rel=1e-10)
    assert result.cost_history[-1] == pytest.approx(result.cost)
    np.testing.assert_allclose(result.times, np.linspace(0.0, TOTAL_TIME, STATES))


def test_straight_line_through_an_obstacle_becomes_collision_free():
    planner, initial, _, result = _solve_problem('diagonal_through_disc', 'vectorised')
    assert planner.clearance(initial, TOTAL_TIME) < -0.5            # the line crosses the disc
    assert result.collision_free
    assert result.min_clearance > 0.15                              # close to epsilon = 0.2 (soft hinge)
    assert result.min_clearance == pytest.approx(planner.clearance(result.trajectory, TOTAL_TIME))
    np.testing.assert_allclose(result.trajectory[0], initial[0], atol=1e-3)
    np.testing.assert_allclose(result.trajectory[-1], initial[-1], atol=1e-3)


def test_interpolated_obstacle_checks_stop_tunnelling_between_states():
    # Support states alone may jump across the small disc at (1.0, 3.8); checks in between cannot.
    initial = straight_line((0.3, 4.0), (4.6, 0.6), STATES, TOTAL_TIME)
    states_only = GPPlanner(GPPlannerConfig(epsilon=0.2), SDF).plan(initial, TOTAL_TIME)
    interpolated = GPPlanner(GPPlannerConfig(epsilon=0.2, obstacle_interpolation=2), SDF).plan(initial, TOTAL_TIME)
    assert SDF.query(states_only.trajectory[:, :2])[0].min() > 0.1   # every support state is clear ...
    assert not states_only.collision_free                           # ... but the motion between them is not
    assert interpolated.collision_free and interpolated.min_clearance > 0.15


def test_robot_radius_inflates_obstacles():
    initial = straight_line((0.3, 2.0), (4.6, 3.4), STATES, TOTAL_TIME)
    slim = GPPlanner(GPPlannerConfig(epsilon=0.1), SDF).plan(initial, TOTAL_TIME)
    wide = GPPlanner(GPPlannerConfig(epsilon=0.1, robot_radius=0.3), SDF).plan(initial, TOTAL_TIME)
    centre_distance = lambda result: SDF.query(result.trajectory[:, :2])[0].min()   # noqa: E731
    assert wide.collision_free and slim.collision_free
    assert centre_distance(wide) > 0.3 + 0.05
    assert centre_distance(wide) > centre_distance(slim) + 0.2


def test_velocity_limit_factor_caps_the_speed():
    initial = straight_line((0.5, 0.5), (4.5, 4.4), STATES, TOTAL_TIME)
    initial[[0, -1], 2:] = 0.0                                      # start and stop at rest
    free = GPPlanner(GPPlannerConfig(epsilon=0.2), SDF).plan(initial, TOTAL_TIME)
    limited = GPPlanner(GPPlannerConfig(epsilon=0.2, max_speed=0.3, sigma_velocity=0.005), SDF).plan(
        initial, TOTAL_TIME)
    speed = lambda result: np.linalg.norm(result.trajectory[:, 2:], axis=1).max()   # noqa: E731
    assert speed(free) > 0.38
    assert speed(limited) <= 0.3 + 0.005
    assert limited.term_costs['velocity_limit'] < 1e-3
    assert limited.collision_free


def test_other_robots_trajectory_pushes_the_plan_away():
    times, positions = _other_robot_crossing()
    planner = GPPlanner(GPPlannerConfig(epsilon=0.15), SDF)
    initial = straight_line((0.4, 0.3), (4.6, 0.3), STATES, TOTAL_TIME)
    alone = planner.plan(initial, TOTAL_TIME)
    term = MovingObstacleTerm.from_timed_positions(times, positions, alone.times, combined_radius=0.4,
                                                   epsilon=0.1, sigma=0.05)
    shared = planner.plan(initial, TOTAL_TIME, extra_terms=[term])
    separation = lambda result: np.linalg.norm(result.trajectory[:, :2] - positions, axis=1).min()  # noqa: E731
    assert separation(alone) < 0.2
    assert separation(shared) > 0.4 + 0.09                          # combined radius + most of epsilon
    assert shared.term_costs['moving_obstacles'] < 1e-2
    assert shared.collision_free


def test_replan_warm_starts_from_the_previous_solution():
    planner, initial, _, first = _solve_problem('diagonal_through_disc', 'vectorised')
    again = planner.plan(first.trajectory, TOTAL_TIME, start=initial[0], goal=initial[-1])
    assert again.initial_cost == pytest.approx(first.cost, rel=1e-12)
    assert again.iterations <= 2
    assert again.cost <= first.cost * (1 + 1e-9)
    # A new start from tracking (robot 5 cm off) re-converges quickly from the warm start.
    moved = initial[0] + np.array([0.05, -0.03, 0.0, 0.0])
    replan = planner.plan(first.trajectory, TOTAL_TIME, start=moved, goal=initial[-1])
    cold = planner.plan(straight_line(moved[:2], initial[-1, :2], STATES, TOTAL_TIME), TOTAL_TIME,
                        start=moved, goal=initial[-1])
    np.testing.assert_allclose(replan.trajectory[0], moved, atol=1e-3)
    assert replan.collision_free
    assert replan.iterations < cold.iterations


def test_iteration_cap_stops_the_optimiser():
    initial = straight_line((0.5, 0.5), (4.5, 4.4), STATES, TOTAL_TIME)
    for formulation in ('vectorised', 'gtsam'):
        result = GPPlanner(GPPlannerConfig(max_iterations=2), SDF).plan(initial, TOTAL_TIME, formulation=formulation)
        assert result.iterations == 2 and not result.converged
        assert result.cost < result.initial_cost


def test_sparse_fallback_solves_the_same_system(monkeypatch):
    *_, banded = _solve_problem('diagonal_through_disc', 'vectorised')
    monkeypatch.setattr(gp_vectorised, 'MAX_BAND', 0)
    *_, sparse = _solve_problem('diagonal_through_disc', 'vectorised')
    assert sparse.cost == pytest.approx(banded.cost, rel=1e-9)
    assert sparse.iterations == banded.iterations


# ---------------------------------------------------------------- bad input

@pytest.mark.parametrize('field, value, message', [
    ('sigma_obs', -0.1, r'GPPlannerConfig.sigma_obs: must be > 0 \(got -0.1\)'),
    ('sigma_obs', float('nan'), 'GPPlannerConfig.sigma_obs: must be finite'),
    ('sigma_start_position', 0.0, 'GPPlannerConfig.sigma_start_position: must be > 0'),
    ('epsilon', -0.01, 'GPPlannerConfig.epsilon: must be >= 0'),
    ('robot_radius', float('inf'), 'GPPlannerConfig.robot_radius: must be finite'),
    ('qc', (1.0, -2.0), r'GPPlannerConfig.qc\[1\]: must be > 0'),
    ('qc', (1.0, 2.0, 3.0), 'GPPlannerConfig.qc: must be one number or two'),
    ('qc', 'big', 'GPPlannerConfig.qc: must be a number'),
    ('max_speed', 0.0, 'GPPlannerConfig.max_speed: must be > 0'),
    ('max_iterations', 0, 'GPPlannerConfig.max_iterations: must be >= 1'),
    ('max_iterations', 2.5, 'GPPlannerConfig.max_iterations: must be an integer'),
    ('obstacle_interpolation', -1, 'GPPlannerConfig.obstacle_interpolation: must be >= 0'),
    ('relative_error_tol', True, 'GPPlannerConfig.relative_error_tol: must be a number'),
    ('formulation', 'ceres', 'GPPlannerConfig.formulation: must be one of vectorised, gtsam'),
])
def test_bad_configuration_names_the_field(field, value, message):
    with pytest.raises(ValueError, match=message):
        GPPlannerConfig(**{field: value})


def test_config_from_mapping():
    config = GPPlannerConfig.from_mapping({'qc': 0.5, 'sigma_obs': 0.15, 'max_speed': None}, path='roles.gp')
    assert config.qc == (0.5, 0.5) and config.sigma_obs == 0.15 and config.max_speed is None
    with pytest.raises(ValueError, match=r'roles.gp.sigma: unknown key \(allowed: qc, sigma_obs'):
        GPPlannerConfig.from_mapping({'sigma': 0.1}, path='roles.gp')
    with pytest.raises(ValueError, match=r'roles.gp.epsilon: must be >= 0'):
        GPPlannerConfig.from_mapping({'epsilon': -1}, path='roles.gp')
    with pytest.raises(ValueError, match='roles.gp: must be a mapping'):
        GPPlannerConfig.from_mapping([('qc', 1.0)], path='roles.gp')


def _bad_state_trajectory():
    trajectory = straight_line((0, 0), (1, 1), 5, 5.0)
    trajectory[3, 2] = np.nan
    return trajectory


@pytest.mark.parametrize('arguments, message', [
    (dict(initial=np.zeros((10, 3))), r'initial: must have shape \(N\+1, 4\)'),
    (dict(initial=np.zeros((1, 4))), r'initial: must have shape \(N\+1, 4\) with N\+1 >= 2'),
    (dict(initial=_bad_state_trajectory()), r'initial\[3, 2\]: must be finite'),
    (dict(initial=[['a', 1, 2, 3]] * 2), r'initial: must be a numeric array'),
    (dict(total_time=0.0), 'total_time: must be > 0'),
    (dict(total_time=float('nan')), 'total_time: must be finite'),
    (dict(start=[0.0, 0.0]), r'start: must have shape \(4,\)'),
    (dict(goal=[0.0, 0.0, np.inf, 0.0]), 'goal: must be finite'),
    (dict(formulation='ceres'), 'formulation: must be one of vectorised, gtsam'),
    (dict(extra_terms=['not a term']), r'extra_terms\[0\]: must be a CostTerm'),
    (dict(extra_terms=[MovingObstacleTerm(np.zeros((1, 2)), [7], 0.1, 0.1, 0.1)]),
     r'extra_terms\[0\].state_indices: must lie in \[0, 4\]'),
])
def test_bad_plan_input_names_the_argument(arguments, message):
    planner = GPPlanner(GPPlannerConfig(), SDF)
    call = dict(initial=straight_line((0, 0), (1, 1), 5, 5.0), total_time=5.0)
    call.update(arguments)
    initial, total_time = call.pop('initial'), call.pop('total_time')
    with pytest.raises(ValueError, match=message):
        planner.plan(initial, total_time, **call)


def test_planner_rejects_an_sdf_without_query():
    with pytest.raises(ValueError, match=r'sdf: must have a query\(points\)'):
        GPPlanner(GPPlannerConfig(), object())


@pytest.mark.parametrize('formulation', ['vectorised', 'gtsam'])
def test_a_faulty_sdf_is_reported_by_both_formulations(formulation):
    class OffByOne:
        def query(self, points):
            return np.zeros(len(points) + 1), np.zeros((len(points), 2))

    planner = GPPlanner(GPPlannerConfig(), OffByOne())
    with pytest.raises(ValueError, match='sdf.query: must return distance'):
        planner.plan(straight_line((0, 0), (1, 1), 5, 5.0), 5.0, formulation=formulation)

"""Compiled GP formulation (core.gp_compiled + core.gp_kernels) against its references: the kernels'
residuals and Jacobians equal the terms' numpy ones, finite differences and gtsam's linearised
factors; the block-Cholesky solve equals scipy's banded one; final costs equal gtsam's to 1e-9 on
small problems with every factor kind; problems the kernels cannot take run the vectorised path."""
import gtsam
import numpy as np
import pytest
import scipy.linalg

from role_engine.core import gp_compiled, gp_kernels
from role_engine.core.conflict import SharedRole
from role_engine.core.environment import Environment, RobotType
from role_engine.core.gp_costs import (GPPriorTerm, InterpolatedMovingObstacleTerm, InterpolatedObstacleTerm,
                                       MovingObstacleTerm, ObstacleTerm, StatePriorTerm, VelocityLimitTerm)
from role_engine.core.gp_gtsam import term_factors, values_from_states
from role_engine.core.gp_planner import GPPlanner, GPPlannerConfig
from role_engine.core.gp_vectorised import LMSettings
from role_engine.core.initial_paths import straight_line_trajectory
from role_engine.core.role_playing import AvoidanceSettings, replan_process_role
from role_engine.core.sdf import SignedDistanceField

from roles_gp_helpers import AnalyticSDF, straight_line

TOTAL_TIME = 10.0
STATES = 25
RESOLUTION = 0.05


def _grid_sdf() -> SignedDistanceField:
    """A 5 m x 4 m grid with a disc and a box (cells at 5 cm), walls at the border."""
    ys, xs = np.mgrid[0:80, 0:100]
    centres_x, centres_y = (xs + 0.5) * RESOLUTION, (ys + 0.5) * RESOLUTION
    occupied = np.hypot(centres_x - 2.5, centres_y - 2.0) < 0.5
    occupied |= (np.abs(centres_x - 3.9) < 0.3) & (np.abs(centres_y - 1.0) < 0.5)
    return SignedDistanceField.from_occupancy(occupied, RESOLUTION, (0.0, 0.0), border_is_obstacle=True)


SDF = _grid_sdf()


def _crossing(count, y_range=(0.4, 3.5)):
    """Another robot going along x = 2.4 over the plan's time."""
    times = np.linspace(0.0, TOTAL_TIME, count)
    return times, np.column_stack([np.full(count, 2.4), np.linspace(*y_range, count)])


def _all_terms(states: np.ndarray) -> list:
    """One term of every kind the kernels know, on a problem of STATES states."""
    dt = TOTAL_TIME / (STATES - 1)
    times, positions = _crossing(STATES)
    inner = InterpolatedMovingObstacleTerm.instants(times, 2)
    between = np.column_stack([np.full(inner.size, 2.4), np.interp(inner, times, positions[:, 1])])
    return [GPPriorTerm(STATES, dt, np.array([1.0, 0.5])),
            StatePriorTerm('start', 0, states[0], 1e-3, 1e-2),
            StatePriorTerm('goal', STATES - 1, states[-1], 1e-3, 1e-2),
            ObstacleTerm(SDF, STATES, 0.25, 0.1, robot_radius=0.05),
            InterpolatedObstacleTerm(SDF, STATES, dt, 3, 0.25, 0.1, robot_radius=0.05),
            VelocityLimitTerm(STATES, 0.35, 0.05),
            MovingObstacleTerm(positions, np.arange(STATES), 0.3, 0.2, 0.05),
            InterpolatedMovingObstacleTerm(between, STATES, dt, 2, 0.3, 0.2, 0.05)]


def _states(seed=0) -> np.ndarray:
    """A wiggly path across the map (so hinges are active and inactive, speeds above and below)."""
    rng = np.random.default_rng(seed)
    line = straight_line((0.4, 1.9), (4.6, 2.3), STATES, TOTAL_TIME)
    line[:, :2] += rng.normal(scale=0.15, size=(STATES, 2))
    line[:, 2:] += rng.normal(scale=0.2, size=(STATES, 2))
    return line


def _term_rows(problem, term_index):
    _, linear, rows = problem.slices[term_index]
    return linear, rows


def _dense_jacobian(term, states):
    """The term's whitened Jacobians (M, r, 8) in the kernels' [x_i0, x_i1] column layout."""
    _, jacobians = term.evaluate(states)
    out = np.zeros(jacobians.shape[:2] + (8,))
    out[:, :, :jacobians.shape[2]] = jacobians
    return out


@pytest.mark.parametrize('seed', [0, 1, 2])
def test_kernel_residuals_and_jacobians_equal_the_terms(seed):
    states = _states(seed)
    terms = _all_terms(states)
    problem = gp_compiled.CompiledProblem(terms, STATES)
    cost, r_lin, r_hin, j_hin = problem.evaluate(states)
    total = 0.0
    for index, term in enumerate(terms):
        linear, rows = _term_rows(problem, index)
        residuals, _ = term.evaluate(states)
        jacobians = _dense_jacobian(term, states)
        if linear:
            np.testing.assert_allclose(r_lin[rows], residuals, rtol=1e-12, atol=1e-9, err_msg=term.name)
            np.testing.assert_allclose(np.broadcast_to(problem.lin_j[rows], jacobians.shape), jacobians,
                                       rtol=1e-12, atol=1e-9, err_msg=term.name)
        else:
            np.testing.assert_allclose(r_hin[rows], residuals[:, 0], rtol=1e-12, atol=1e-12, err_msg=term.name)
            np.testing.assert_allclose(j_hin[rows], jacobians[:, 0], rtol=1e-12, atol=1e-12, err_msg=term.name)
        total += term.cost(states)
    assert cost == pytest.approx(total, rel=1e-13)
    # Every kind is exercised: some hinges active, some not.
    assert 0 < np.count_nonzero(r_hin) < r_hin.size


def test_kernel_jacobians_match_finite_differences():
    states = _states(3)
    problem = gp_compiled.CompiledProblem(_all_terms(states), STATES)
    _, r_lin, r_hin, j_hin = problem.evaluate(states)
    step = 1e-7
    numeric_lin = np.zeros(problem.lin_j.shape)
    numeric_hin = np.zeros(j_hin.shape)
    for k in range(STATES):
        for c in range(4):
            plus, minus = states.copy(), states.copy()
            plus[k, c] += step
            minus[k, c] -= step
            _, lin_p, hin_p, _ = problem.evaluate(plus)
            _, lin_m, hin_m, _ = problem.evaluate(minus)
            first_l, second_l = problem.lin_i0 == k, problem.lin_i1 == k
            numeric_lin[first_l, :, c] = ((lin_p - lin_m) / (2 * step))[first_l]
            numeric_lin[second_l, :, 4 + c] = ((lin_p - lin_m) / (2 * step))[second_l]
            first_h, second_h = problem.hin_i0 == k, problem.hin_i1 == k
            numeric_hin[first_h, c] = ((hin_p - hin_m) / (2 * step))[first_h]
            numeric_hin[second_h, 4 + c] = ((hin_p - hin_m) / (2 * step))[second_h]
    np.testing.assert_allclose(numeric_lin, problem.lin_j, rtol=1e-6, atol=1e-4)
    # Hinges are piecewise smooth (kink at epsilon, bilinear cells): compare away from the kinks.
    smooth = np.all(np.abs(numeric_hin - j_hin) < 1e-4 * (1.0 + np.abs(j_hin)), axis=1)
    assert smooth.mean() > 0.97, f'{np.count_nonzero(~smooth)} of {smooth.size} hinge rows differ'


def _gtsam_columns(factor, i0):
    """The kernels' columns (of [x_i0, x_i1]) of each of a gtsam factor's keys, in key order."""
    columns = []
    for key in factor.keys():
        symbol = gtsam.Symbol(key)
        offset = 4 * (symbol.index() - i0) + (0 if chr(symbol.chr()) == 'x' else 2)
        columns += [offset, offset + 1]
    return columns


def test_kernel_residuals_and_jacobians_equal_gtsams_linearised_factors():
    states = _states(4)
    terms = _all_terms(states)
    problem = gp_compiled.CompiledProblem(terms, STATES)
    _, r_lin, r_hin, j_hin = problem.evaluate(states)
    values = values_from_states(states)
    for index, term in enumerate(terms):
        linear, rows = _term_rows(problem, index)
        factors = term_factors(term)
        row_ids = np.arange(rows.start, rows.stop)
        if isinstance(term, StatePriorTerm):       # one packed row, two gtsam priors (position, velocity)
            pairs = [(row_ids[0], slice(0, 2)), (row_ids[0], slice(2, 4))]
        else:
            pairs = [(row, slice(0, 4) if linear else slice(0, 1)) for row in row_ids]
        assert len(pairs) == len(factors), term.name
        for factor, (row, part) in zip(factors, pairs):
            a, b = factor.linearize(values).jacobian()
            i0 = (problem.lin_i0 if linear else problem.hin_i0)[row]
            columns = _gtsam_columns(factor, i0)
            residual = r_lin[row, part] if linear else r_hin[row:row + 1]
            jacobian = problem.lin_j[row][part][:, columns] if linear else j_hin[row:row + 1, columns]
            np.testing.assert_allclose(residual, -b, rtol=1e-9, atol=1e-9, err_msg=term.name)
            np.testing.assert_allclose(jacobian, a, rtol=1e-9, atol=1e-9, err_msg=term.name)
            assert 0.5 * np.sum(residual ** 2) == pytest.approx(factor.error(values), rel=1e-9, abs=1e-15)


def test_sdf_kernel_equals_the_field_query_inside_and_beyond_the_grid():
    rng = np.random.default_rng(5)
    points = np.vstack([rng.uniform(-0.5, 5.5, size=(300, 2)), [[0.0, 0.0], [5.0, 4.0], [2.5, 2.0]]])
    distance, gradient = SDF.query(points)
    for point, d, g in zip(points, distance, gradient):
        got = gp_kernels.sdf_query(SDF.data, SDF.origin[0], SDF.origin[1], SDF.resolution, point[0], point[1])
        assert got == pytest.approx((d, g[0], g[1]), rel=1e-14, abs=1e-15)


def test_block_cholesky_solve_equals_scipys_banded_solve():
    rng = np.random.default_rng(6)
    n = 9
    pair = np.arange(60) % (n - 1)              # row r reads states pair[r] and pair[r] + 1, as the factors do
    reads = (np.arange(4 * n) // 4)[None, :] - pair[:, None]
    jac = rng.normal(size=(60, 4 * n)) * ((reads == 0) | (reads == 1))
    hessian = jac.T @ jac
    gradient = rng.normal(size=4 * n)
    diag = np.array([hessian[4 * k:4 * k + 4, 4 * k:4 * k + 4] for k in range(n)])
    sub = np.array([hessian[4 * k + 4:4 * k + 8, 4 * k:4 * k + 4] for k in range(n - 1)])
    delta = np.empty((n, 4))
    for damping in (1e-3, 1.0, 1e3):
        ok = gp_kernels.solve_damped(diag, sub, gradient.reshape(n, 4), damping, np.empty((n, 4, 4)),
                                     np.empty((n - 1, 4, 4)), delta)
        band = np.array([np.concatenate([np.diagonal(hessian, -d), np.zeros(d)]) for d in range(8)])
        band[0] += damping
        expected = scipy.linalg.solveh_banded(band, -gradient, lower=True)
        assert ok
        np.testing.assert_allclose(delta.reshape(-1), expected, rtol=1e-9, atol=1e-12)
    indefinite = diag.copy()
    indefinite[3] -= 1e6 * np.eye(4)
    assert not gp_kernels.solve_damped(indefinite, sub, gradient.reshape(n, 4), 1.0, np.empty((n, 4, 4)),
                                       np.empty((n - 1, 4, 4)), delta)


PROBLEMS = {
    'through_the_disc': dict(start=(0.4, 1.9), goal=(4.6, 2.2), config={}),
    'interpolated_and_speed_limit': dict(start=(0.4, 3.4), goal=(4.6, 0.3),
                                         config=dict(obstacle_interpolation=3, max_speed=0.5, robot_radius=0.05)),
    'other_robot_crossing': dict(start=(0.4, 0.3), goal=(4.6, 0.35), config=dict(epsilon=0.15), moving=True),
    'damped_start': dict(start=(0.4, 1.9), goal=(4.6, 2.2), config=dict(lambda_initial=1000.0,
                                                                        obstacle_interpolation=1)),
}


def _plan(name, formulation):
    problem = PROBLEMS[name]
    planner = GPPlanner(GPPlannerConfig(**{'sigma_obs': 0.1, 'epsilon': 0.2, **problem['config']}), SDF)
    extra = []
    if problem.get('moving'):
        times, positions = _crossing(40, (1.2, -0.6))      # meets the own line y = 0.3 at mid-time
        extra.append(MovingObstacleTerm.from_timed_positions(times, positions, np.linspace(0, TOTAL_TIME, STATES),
                                                             combined_radius=0.4, epsilon=0.1, sigma=0.05))
        inner = InterpolatedMovingObstacleTerm.instants(np.linspace(0, TOTAL_TIME, STATES), 2)
        between = np.column_stack([np.full(inner.size, 2.4), np.interp(inner, times, positions[:, 1])])
        extra.append(InterpolatedMovingObstacleTerm(between, STATES, TOTAL_TIME / (STATES - 1), 2, 0.4, 0.1, 0.05))
    initial = straight_line(problem['start'], problem['goal'], STATES, TOTAL_TIME)
    return planner.plan(initial, TOTAL_TIME, extra_terms=extra, formulation=formulation)


@pytest.mark.parametrize('name', sorted(PROBLEMS))
def test_final_costs_equal_gtsams_to_1e9(name):
    compiled, vectorised, graph = (_plan(name, f) for f in ('compiled', 'vectorised', 'gtsam'))
    assert compiled.formulation == 'compiled'
    assert compiled.initial_cost == pytest.approx(graph.initial_cost, rel=1e-12)
    assert compiled.cost < 0.5 * compiled.initial_cost
    assert abs(compiled.cost - graph.cost) <= 1e-9 * graph.cost
    assert abs(compiled.cost - vectorised.cost) <= 1e-9 * vectorised.cost
    assert compiled.iterations == graph.iterations == vectorised.iterations
    assert compiled.converged == graph.converged
    np.testing.assert_allclose(compiled.trajectory, graph.trajectory, atol=1e-7)
    assert compiled.term_costs.keys() == graph.term_costs.keys()
    for term, cost in compiled.term_costs.items():
        assert cost == pytest.approx(graph.term_costs[term], rel=1e-7, abs=1e-12), term
    assert compiled.min_clearance == pytest.approx(graph.min_clearance, abs=1e-7)
    assert len(compiled.cost_history) == len(vectorised.cost_history)


def test_the_compiled_path_is_the_default_and_problems_it_cannot_take_run_the_vectorised_one():
    assert GPPlannerConfig().formulation == 'compiled'
    initial = straight_line((0.4, 1.9), (4.6, 2.2), STATES, TOTAL_TIME)
    assert GPPlanner(GPPlannerConfig(), SDF).plan(initial, TOTAL_TIME).formulation == 'compiled'
    analytic = AnalyticSDF(circles=[(2.5, 2.0, 0.5)])
    fallback = GPPlanner(GPPlannerConfig(), analytic).plan(initial, TOTAL_TIME)
    reference = GPPlanner(GPPlannerConfig(), analytic).plan(initial, TOTAL_TIME, formulation='vectorised')
    assert fallback.formulation == 'vectorised' and fallback.cost == reference.cost
    planner = GPPlanner(GPPlannerConfig(), SDF)
    terms = planner.terms(STATES, TOTAL_TIME, initial[0], initial[-1])
    assert gp_compiled.unsupported_reason(terms, STATES) is None
    assert 'AnalyticSDF' in gp_compiled.unsupported_reason(
        GPPlanner(GPPlannerConfig(), analytic).terms(STATES, TOTAL_TIME, initial[0], initial[-1]), STATES)

    class Scaled(MovingObstacleTerm):          # a subclass may change the errors: not assumed packable
        pass

    odd = Scaled(np.zeros((1, 2)), [3], 0.2, 0.1, 0.1)
    assert 'Scaled' in gp_compiled.unsupported_reason(terms + [odd], STATES)
    assert planner.plan(initial, TOTAL_TIME, extra_terms=[odd]).formulation == 'vectorised'


def test_warm_up_and_settings_reach_the_kernel():
    gp_compiled.warm_up()
    gp_compiled.warm_up()                      # idempotent
    initial = straight_line((0.4, 1.9), (4.6, 2.2), STATES, TOTAL_TIME)
    planner = GPPlanner(GPPlannerConfig(max_iterations=2), SDF)
    capped = planner.plan(initial, TOTAL_TIME)
    assert capped.iterations == 2 and not capped.converged and len(capped.cost_history) == 2
    problem = gp_compiled.CompiledProblem(planner.terms(STATES, TOTAL_TIME, initial[0], initial[-1]), STATES)
    with pytest.raises(Exception, match='shape'):
        gp_compiled.optimise(problem, initial[:-1], LMSettings())


def test_role_player_replans_use_the_compiled_path_and_match_gtsam():
    occupied = np.zeros((60, 80), dtype=bool)
    occupied[25:35, 38:42] = True
    environment = Environment(occupied, RESOLUTION, (-2.0, -1.5), name='open')
    view = environment.for_robot(RobotType('small', 0.1))
    own = SharedRole('a', straight_line_trajectory((-1.5, 0.0), (1.5, 0.0), TOTAL_TIME, 20), TOTAL_TIME, 0.1)
    other = SharedRole('b', straight_line_trajectory((1.5, 0.1), (-1.5, 0.1), TOTAL_TIME, 20), TOTAL_TIME, 0.1)
    config = dict(sigma_obs=0.1, epsilon=0.15, lambda_initial=1000.0)
    results = {f: replan_process_role(GPPlannerConfig(**config, formulation=f), view, own, [other], 2.0,
                                      own.positions([2.0])[0], horizon=4.0,
                                      avoidance=AvoidanceSettings(detour_scales=(1.0,)))
               for f in ('compiled', 'gtsam')}
    assert results['compiled'].candidates == results['gtsam'].candidates
    assert results['compiled'].initialisation == results['gtsam'].initialisation
    assert results['compiled'].cost == pytest.approx(results['gtsam'].cost, rel=1e-9)

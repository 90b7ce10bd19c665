"""Cost terms of GP inference: the hinge loss (Eq. 21), obstacle / velocity / moving-obstacle
factors (Eq. 20, 22) against finite differences, and gtsam's view of the same factors."""
import gtsam
import numpy as np
import pytest

from role_engine.core.gp_costs import (GPPriorTerm, InterpolatedMovingObstacleTerm, InterpolatedObstacleTerm,
                                       MovingObstacleTerm, ObstacleTerm, StatePriorTerm, VelocityLimitTerm,
                                       hinge_loss, query_sdf)
from role_engine.core.gp_prior import interpolate_states
from role_engine.core.gp_gtsam import build_graph, values_from_states

from roles_gp_helpers import AnalyticSDF

SDF = AnalyticSDF(circles=[(1.0, 1.0, 0.4), (2.6, 0.9, 0.3)], boxes=[(2.0, 2.2, 0.5, 0.25)])


def _numerical_jacobian(term, local_states, factor_ids, step=1e-6):
    """Central differences of the unwhitened errors w.r.t. every local state component."""
    m, s, _ = local_states.shape
    jac = np.zeros((m, term.residual_dim, 4 * s))
    for q in range(s):
        for c in range(4):
            plus, minus = local_states.copy(), local_states.copy()
            plus[:, q, c] += step
            minus[:, q, c] -= step
            jac[:, :, 4 * q + c] = (term.errors(plus, factor_ids, False)[0]
                                    - term.errors(minus, factor_ids, False)[0]) / (2 * step)
    return jac


# ---------------------------------------------------------------- hinge loss (Eq. 21)

def test_hinge_loss_values_follow_eq21():
    eps = 0.2
    d = np.array([-0.5, 0.0, 0.1, 0.2, 0.3, 2.0])
    cost, slope = hinge_loss(d, eps)
    np.testing.assert_allclose(cost, [0.7, 0.2, 0.1, 0.0, 0.0, 0.0])
    np.testing.assert_array_equal(slope, [-1.0, -1.0, -1.0, -1.0, 0.0, 0.0])


def test_hinge_loss_gradient_matches_finite_differences_on_both_sides_of_the_kink():
    eps = 0.15
    step = 1e-7
    for d in (-0.3, 0.0, 0.1, eps - 1e-4, eps + 1e-4, 0.4):
        _, slope = hinge_loss(np.array([d]), eps)
        fd = (hinge_loss(np.array([d + step]), eps)[0] - hinge_loss(np.array([d - step]), eps)[0]) / (2 * step)
        assert slope[0] == pytest.approx(fd[0], abs=1e-6), d


def test_hinge_loss_is_continuous_at_the_kink_with_the_left_derivative():
    eps = 0.15
    cost, slope = hinge_loss(np.array([eps]), eps)
    assert cost[0] == 0.0 and slope[0] == -1.0
    below, _ = hinge_loss(np.array([eps - 1e-9]), eps)
    above, _ = hinge_loss(np.array([eps + 1e-9]), eps)
    assert below[0] == pytest.approx(1e-9, abs=1e-12) and above[0] == 0.0
    # Left difference quotient at the kink equals the returned derivative; the right one is 0.
    h = 1e-7
    assert (cost[0] - hinge_loss(np.array([eps - h]), eps)[0][0]) / h == pytest.approx(-1.0)
    assert (hinge_loss(np.array([eps + h]), eps)[0][0] - cost[0]) / h == 0.0


# ---------------------------------------------------------------- factors vs finite differences

def _states_near_obstacles(count, seed):
    rng = np.random.default_rng(seed)
    states = np.zeros((count, 4))
    states[:, :2] = rng.uniform([0.4, 0.4], [3.0, 2.6], size=(count, 2))
    states[:, 2:] = rng.normal(scale=0.3, size=(count, 2))
    return states


def _keep_away_from_kinks(term, states, eps, margin=1e-3):
    """Drop states whose SDF value is within ``margin`` of the hinge kink or of the medial axis."""
    distance, _ = SDF.query(states[:, :2])
    return states[np.abs(distance - term.robot_radius - eps) > margin]


def test_obstacle_factor_error_is_the_hinge_of_the_sdf_minus_radius():
    states = np.array([[1.0, 1.45, 0.0, 0.0], [1.0, 1.7, 0.0, 0.0], [1.0, 1.0, 0.0, 0.0]])
    term = ObstacleTerm(SDF, 3, epsilon=0.2, sigma=0.5, robot_radius=0.1)
    errors, _ = term.errors(states[:, None, :], np.arange(3))
    # Distances to the disc at (1, 1) r 0.4: 0.05, 0.3, -0.4; minus radius 0.1; hinge at 0.2.
    np.testing.assert_allclose(errors[:, 0], [0.25, 0.0, 0.7], atol=1e-12)
    whitened, _ = term.evaluate(states)
    np.testing.assert_allclose(whitened[:, 0], errors[:, 0] / 0.5)


def test_obstacle_factor_jacobian_matches_finite_differences():
    term = ObstacleTerm(SDF, 60, epsilon=0.3, sigma=0.1, robot_radius=0.05)
    states = _keep_away_from_kinks(term, _states_near_obstacles(60, 1), 0.3)
    local = states[:, None, :]
    ids = np.arange(len(states))
    _, jac = term.errors(local, ids)
    active = np.abs(jac).sum(axis=(1, 2)) > 0
    assert active.sum() >= 10, 'the sample must exercise active hinges'
    np.testing.assert_allclose(jac, _numerical_jacobian(term, local, ids), atol=1e-6)


def test_interpolated_obstacle_factor_jacobian_matches_finite_differences():
    count = 3
    states = _states_near_obstacles(21, 2)
    term = InterpolatedObstacleTerm(SDF, 21, dt=0.4, count=count, epsilon=0.3, sigma=0.1, robot_radius=0.02)
    local = states[term.state_indices]
    ids = np.arange(term.factor_count)
    errors, jac = term.errors(local, ids)
    assert np.count_nonzero(errors) >= 5
    numerical = _numerical_jacobian(term, local, ids)
    # Skip factors whose interpolated point sits on a kink of the hinge or of the SDF.
    smooth = np.abs(np.abs(jac) - np.abs(numerical)).max(axis=(1, 2)) < 1e-4
    assert smooth.mean() > 0.9
    np.testing.assert_allclose(jac[smooth], numerical[smooth], atol=1e-6)


def test_velocity_limit_factor_is_zero_below_the_limit_and_matches_finite_differences_above():
    term = VelocityLimitTerm(4, max_speed=0.5, sigma=0.01)
    states = np.array([[0, 0, 0.3, 0.3], [0, 0, 0.6, 0.0], [0, 0, -0.4, 0.5], [0, 0, 0.0, 0.0]], dtype=float)
    local = states[:, None, :]
    ids = np.arange(4)
    errors, jac = term.errors(local, ids)
    np.testing.assert_allclose(errors[:, 0], [0.0, 0.1, np.hypot(0.4, 0.5) - 0.5, 0.0], atol=1e-12)
    np.testing.assert_allclose(jac, _numerical_jacobian(term, local, ids), atol=1e-7)
    assert not term.uses_position
    # On the boundary |v| = v_max the error is 0 and the factor is active (pushes the speed down).
    boundary = np.array([[[0.0, 0.0, 0.3, 0.4]]])
    errors, jac = term.errors(boundary, np.arange(1))
    assert errors[0, 0] == 0.0
    np.testing.assert_allclose(jac[0, 0, 2:], [0.6, 0.8])


def test_moving_obstacle_factor_and_jacobian():
    others = np.array([[1.0, 1.0], [2.0, 2.0], [0.0, 0.0]])
    term = MovingObstacleTerm(others, [0, 1, 2], combined_radius=0.3, epsilon=0.1, sigma=0.05)
    states = np.array([[1.2, 1.0, 0, 0], [2.0, 2.5, 0, 0], [0.1, 0.2, 0, 0]])
    local = states[:, None, :]
    errors, jac = term.errors(local, np.arange(3))
    # centre distances 0.2, 0.5, hypot(0.1, 0.2) -> distance beyond radius -0.1, 0.2, 0.2236-0.3.
    np.testing.assert_allclose(errors[:, 0], [0.2, 0.0, 0.4 - np.hypot(0.1, 0.2)], atol=1e-12)
    np.testing.assert_allclose(jac, _numerical_jacobian(term, local, np.arange(3)), atol=1e-7)


def _crossing_other(state_count, dt, count):
    """Another robot moving along x = 1.2 upwards: positions at support times and interpolated instants."""
    support = np.arange(state_count) * dt
    instants = InterpolatedMovingObstacleTerm.instants(support, count)
    where = lambda t: np.column_stack([np.full(len(t), 1.2), 0.2 + 0.15 * t])   # noqa: E731
    return support, where(support), instants, where(instants)


def test_interpolated_moving_obstacle_factor_and_jacobian_match_finite_differences():
    count, dt, state_count = 3, 0.5, 8
    support, _, instants, others = _crossing_other(state_count, dt, count)
    term = InterpolatedMovingObstacleTerm(others, state_count, dt, count, combined_radius=0.3, epsilon=0.1,
                                          sigma=0.05)
    rng = np.random.default_rng(4)
    states = np.column_stack([np.linspace(0.6, 1.8, state_count) + 0.05 * rng.standard_normal(state_count),
                              np.linspace(0.3, 0.6, state_count), 0.3 * rng.standard_normal((state_count, 2))])
    ids = np.arange(term.factor_count)
    local = states[term.state_indices]
    errors, jac = term.errors(local, ids)
    # The factors compare the GP-interpolated own position with the other at the same instant.
    own = interpolate_states(states, dt, count)
    inner = np.delete(own, np.arange(0, len(own), count + 1), axis=0)[:, :2]
    distance = np.linalg.norm(inner - others, axis=1) - 0.3
    np.testing.assert_allclose(errors[:, 0], np.where(distance <= 0.1, 0.1 - distance, 0.0), atol=1e-12)
    assert np.count_nonzero(errors) >= 3                              # the check below is not vacuous
    np.testing.assert_allclose(jac, _numerical_jacobian(term, local, ids), atol=1e-6)
    assert term.uses_velocity and term.uses_position
    np.testing.assert_allclose(instants[:count], dt * np.arange(1, count + 1) / (count + 1))


def test_interpolated_moving_obstacle_sees_robots_passing_between_support_states():
    # Support states 1 s apart: the other robot is clear of them but crosses the path in between.
    support = np.array([0.0, 1.0])
    states = np.array([[0.0, 0.0, 1.0, 0.0], [1.0, 0.0, 1.0, 0.0]])
    others_at_support = np.array([[-1.0, 0.0], [2.0, 0.0]])
    instants = InterpolatedMovingObstacleTerm.instants(support, 1)     # t = 0.5: both at x = 0.5
    at_support = MovingObstacleTerm(others_at_support, [0, 1], combined_radius=0.3, epsilon=0.1, sigma=0.1)
    between = InterpolatedMovingObstacleTerm([[0.5, 0.0]], 2, 1.0, 1, combined_radius=0.3, epsilon=0.1, sigma=0.1)
    assert instants.tolist() == [0.5]
    assert at_support.cost(states) == 0.0
    assert between.cost(states) == pytest.approx(0.5 * (0.4 / 0.1) ** 2)


@pytest.mark.parametrize('kwargs, message', [
    (dict(count=0), 'count: must be an integer >= 1'),
    (dict(dt=0.0), 'dt: must be finite and > 0'),
    (dict(positions=np.zeros((2, 2))), r'positions: must have shape \(6, 2\)'),
    (dict(sigma=-1.0), 'sigma: must be finite and > 0'),
])
def test_interpolated_moving_obstacle_term_rejects_bad_input(kwargs, message):
    arguments = dict(positions=np.zeros((6, 2)), state_count=4, dt=0.5, count=2, combined_radius=0.2,
                     epsilon=0.1, sigma=0.1)
    arguments.update(kwargs)
    with pytest.raises(ValueError, match='moving_obstacles_interpolated.' + message):
        InterpolatedMovingObstacleTerm(**arguments)


def test_moving_obstacles_from_timed_positions_resample_and_hold_the_ends():
    term = MovingObstacleTerm.from_timed_positions(
        times=[1.0, 3.0], positions=[[0.0, 0.0], [2.0, 4.0]], own_times=[0.0, 1.0, 2.0, 3.0, 4.0],
        combined_radius=0.2, epsilon=0.05, sigma=0.1)
    np.testing.assert_allclose(term.positions, [[0, 0], [0, 0], [1, 2], [2, 4], [2, 4]])
    np.testing.assert_array_equal(term.state_indices[:, 0], [0, 1, 2, 3, 4])


@pytest.mark.parametrize('kwargs, message', [
    (dict(positions=np.zeros((2, 2)), state_indices=[0, 1, 2]),
     r'moving_obstacles.positions: must have shape \(3, 2\)'),
    (dict(positions=np.full((1, 2), np.nan), state_indices=[0]), 'moving_obstacles.positions: must be finite'),
    (dict(positions=np.zeros((1, 2)), state_indices=[0], sigma=0.0), 'moving_obstacles.sigma: must be finite and > 0'),
    (dict(positions=np.zeros((1, 2)), state_indices=[0], epsilon=-1.0), 'moving_obstacles.epsilon'),
])
def test_moving_obstacle_term_rejects_bad_input(kwargs, message):
    arguments = dict(combined_radius=0.2, epsilon=0.1, sigma=0.1)
    arguments.update(kwargs)
    with pytest.raises(ValueError, match=message):
        MovingObstacleTerm(**arguments)


def test_sdf_answers_are_checked():
    class WrongShape:
        def query(self, points):
            return np.zeros(len(points) + 1), np.zeros((len(points), 2))

    class NotFinite:
        def query(self, points):
            return np.full(len(points), np.nan), np.zeros((len(points), 2))

    with pytest.raises(ValueError, match=r'sdf.query: must return distance \(2,\)'):
        query_sdf(WrongShape(), np.zeros((2, 2)))
    with pytest.raises(ValueError, match='sdf.query: returned non-finite'):
        query_sdf(NotFinite(), np.zeros((2, 2)))


# ---------------------------------------------------------------- gtsam sees the same cost

def _all_terms(state_count, dt):
    others = np.column_stack([np.linspace(2.5, 0.5, state_count), np.linspace(0.5, 2.5, state_count)])
    return [
        GPPriorTerm(state_count, dt, np.array([0.8, 1.3])),
        StatePriorTerm('start', 0, [0.5, 0.5, 0.1, 0.0], 1e-2, 2e-2),
        StatePriorTerm('goal', state_count - 1, [2.8, 2.5, 0.0, 0.0], 1e-2, 2e-2),
        ObstacleTerm(SDF, state_count, epsilon=0.3, sigma=0.1, robot_radius=0.05),
        InterpolatedObstacleTerm(SDF, state_count, dt, 2, epsilon=0.3, sigma=0.1, robot_radius=0.05),
        VelocityLimitTerm(state_count, max_speed=0.2, sigma=0.05),
        MovingObstacleTerm(others, np.arange(state_count), combined_radius=0.3, epsilon=0.1, sigma=0.2),
        InterpolatedMovingObstacleTerm(_crossing_other(state_count, dt, 2)[3], state_count, dt, 2,
                                       combined_radius=0.3, epsilon=0.2, sigma=0.2),
    ]


@pytest.mark.parametrize('seed', [10, 11, 12])
def test_gtsam_factors_have_the_numpy_cost_and_jacobians(seed):
    count, dt = 15, 0.5
    states = _states_near_obstacles(count, seed)
    for term in _all_terms(count, dt):
        graph = build_graph([term])
        values = values_from_states(states)
        assert graph.error(values) == pytest.approx(term.cost(states), rel=1e-10, abs=1e-12), term.name
        # The whitened normal equations J^T J, J^T r must agree as well (same LM steps).
        residuals, jacobians = term.evaluate(states)
        n = 4 * count
        dense_j = np.zeros((residuals.size, n))
        for j, indices in enumerate(term.state_indices):
            columns = (indices[:, None] * 4 + np.arange(4)).reshape(-1)
            dense_j[j * term.residual_dim:(j + 1) * term.residual_dim, columns] = jacobians[j]
        # Compare on the keys the graph has (the speed limit has no position keys, for example).
        keys_in_graph = {key for i in range(graph.size()) for key in graph.at(i).keys()}
        ordering = gtsam.Ordering()
        columns = []
        for k in range(count):
            for half, key in enumerate((gtsam.symbol_shorthand.X(k), gtsam.symbol_shorthand.V(k))):
                if key in keys_in_graph:
                    ordering.push_back(key)
                    columns.extend([4 * k + 2 * half, 4 * k + 2 * half + 1])
        hessian, eta = graph.linearize(values).hessian(ordering)
        scale = max(1.0, np.abs(dense_j.T @ dense_j).max())
        ours_h = (dense_j.T @ dense_j)[np.ix_(columns, columns)]
        ours_g = -(dense_j.T @ residuals.reshape(-1))[columns]
        assert hessian.shape == ours_h.shape, term.name
        np.testing.assert_allclose(hessian, ours_h, atol=1e-9 * scale, err_msg=term.name)
        np.testing.assert_allclose(eta, ours_g, atol=1e-9 * scale, err_msg=term.name)

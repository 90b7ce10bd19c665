"""Constant-velocity GP prior (Eq. 16-19): closed forms, Jacobians, interpolation and gtsam's factor."""
import gtsam
import numpy as np
import pytest
import scipy.integrate
import scipy.linalg
from gtsam.symbol_shorthand import V, X

from role_engine.core import gp_prior
from role_engine.core.gp_costs import GPPriorTerm
from role_engine.core.gp_gtsam import term_factors, values_from_states

QC = np.array([0.7, 2.5])
A = np.block([[np.zeros((2, 2)), np.eye(2)], [np.zeros((2, 2)), np.zeros((2, 2))]])   # Eq. 18
F = np.vstack([np.zeros((2, 2)), np.eye(2)])


@pytest.mark.parametrize('dt', [0.05, 0.3, 2.0])
def test_transition_matrix_is_the_exponential_of_eq18(dt):
    np.testing.assert_allclose(gp_prior.transition_matrix(dt), scipy.linalg.expm(A * dt), atol=1e-12)


@pytest.mark.parametrize('dt', [0.05, 0.3, 2.0])
def test_process_covariance_is_the_integral_of_eq7(dt):
    # Eq. 7 with K_0 = 0: Q = int_0^dt Phi(dt, s) F Q_c F^T Phi(dt, s)^T ds.
    def integrand(s):
        phi = scipy.linalg.expm(A * (dt - s))
        return phi @ F @ np.diag(QC) @ F.T @ phi.T

    integral, _ = scipy.integrate.quad_vec(integrand, 0.0, dt, epsabs=1e-13)
    np.testing.assert_allclose(gp_prior.process_covariance(dt, QC), integral, rtol=1e-9, atol=1e-14)


def test_process_covariance_matches_eq19_blocks():
    dt = 0.4
    q = gp_prior.process_covariance(dt, QC)
    np.testing.assert_allclose(q[:2, :2], dt ** 3 / 3 * np.diag(QC))
    np.testing.assert_allclose(q[:2, 2:], dt ** 2 / 2 * np.diag(QC))
    np.testing.assert_allclose(q[2:, :2], dt ** 2 / 2 * np.diag(QC))
    np.testing.assert_allclose(q[2:, 2:], dt * np.diag(QC))


def test_scalar_qc_means_the_same_density_on_both_axes():
    np.testing.assert_array_equal(gp_prior.process_covariance(0.2, 1.5), gp_prior.process_covariance(0.2, [1.5, 1.5]))


def test_information_and_whitening_invert_the_covariance():
    dt = 0.25
    q = gp_prior.process_covariance(dt, QC)
    info = gp_prior.process_information(dt, QC)
    np.testing.assert_allclose(info @ q, np.eye(4), atol=1e-9)
    w = gp_prior.whitening_matrix(dt, QC)
    np.testing.assert_allclose(w.T @ w, info, rtol=1e-12)
    np.testing.assert_array_equal(np.tril(w, -1), 0.0)


def test_prior_error_is_the_deviation_from_constant_velocity():
    state_k = np.array([1.0, 2.0, 0.5, -0.25])
    dt = 0.2
    on_prior = gp_prior.transition_matrix(dt) @ state_k
    np.testing.assert_allclose(gp_prior.prior_error(state_k, on_prior, dt), 0.0, atol=1e-15)
    pushed = on_prior + np.array([0.01, 0.0, 0.0, -0.3])
    np.testing.assert_allclose(gp_prior.prior_error(state_k, pushed, dt), [0.01, 0.0, 0.0, -0.3], atol=1e-15)


def test_prior_jacobians_match_finite_differences():
    rng = np.random.default_rng(3)
    dt = 0.37
    x_k, x_kp1 = rng.normal(size=4), rng.normal(size=4)
    h_k, h_kp1 = gp_prior.prior_jacobians(dt)
    step = 1e-6
    for i in range(4):
        e = np.zeros(4)
        e[i] = step
        fd_k = (gp_prior.prior_error(x_k + e, x_kp1, dt) - gp_prior.prior_error(x_k - e, x_kp1, dt)) / (2 * step)
        fd_kp1 = (gp_prior.prior_error(x_k, x_kp1 + e, dt) - gp_prior.prior_error(x_k, x_kp1 - e, dt)) / (2 * step)
        np.testing.assert_allclose(h_k[:, i], fd_k, atol=1e-8)
        np.testing.assert_allclose(h_kp1[:, i], fd_kp1, atol=1e-8)
    np.testing.assert_array_equal(h_k, -gp_prior.transition_matrix(dt))


def test_vectorised_errors_and_cost_match_the_per_interval_formula():
    rng = np.random.default_rng(4)
    states = rng.normal(size=(12, 4))
    dt = 0.15
    expected = np.array([gp_prior.prior_error(states[k], states[k + 1], dt) for k in range(11)])
    np.testing.assert_allclose(gp_prior.prior_errors(states, dt), expected, atol=1e-14)
    info = gp_prior.process_information(dt, QC)
    expected_cost = 0.5 * sum(e @ info @ e for e in expected)
    assert gp_prior.prior_cost(states, dt, QC) == pytest.approx(expected_cost, rel=1e-12)
    assert GPPriorTerm(12, dt, QC).cost(states) == pytest.approx(expected_cost, rel=1e-12)


def test_gtsam_wnoa_factor_has_our_error_covariance_and_jacobians():
    rng = np.random.default_rng(5)
    dt = 0.27
    term = GPPriorTerm(2, dt, QC)
    factor, = term_factors(term)
    assert isinstance(factor, gtsam.WnoaMotionFactorPoint2)
    np.testing.assert_allclose(factor.noiseModel().covariance(), gp_prior.process_covariance(dt, QC), rtol=1e-10)
    info = gp_prior.process_information(dt, QC)
    jacobian = np.hstack(gp_prior.prior_jacobians(dt))
    for _ in range(5):
        states = rng.normal(size=(2, 4))
        values = values_from_states(states)
        ours = gp_prior.prior_error(states[0], states[1], dt)
        np.testing.assert_allclose(factor.unwhitenedError(values), ours, atol=1e-12)
        assert factor.error(values) == pytest.approx(0.5 * ours @ info @ ours, rel=1e-10)
        # The whitened linearisation A (columns x0, v0, x1, v1) must satisfy A^T A = H^T Q^-1 H.
        a, b = factor.linearize(values).jacobian()
        assert list(factor.keys()) == [X(0), V(0), X(1), V(1)]
        np.testing.assert_allclose(a.T @ a, jacobian.T @ info @ jacobian, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(a.T @ b, -jacobian.T @ info @ ours, rtol=1e-9, atol=1e-9)


def test_interpolation_reproduces_the_borders_and_constant_velocity_motion():
    dt = 0.5
    lam, psi = gp_prior.interpolation_matrices(0.0, dt)
    np.testing.assert_array_equal(lam, np.eye(4))
    lam, psi = gp_prior.interpolation_matrices(dt, dt)
    np.testing.assert_allclose(lam, 0.0, atol=1e-12)
    np.testing.assert_allclose(psi, np.eye(4), atol=1e-12)
    state_k = np.array([0.0, 1.0, 0.4, -0.2])
    state_kp1 = gp_prior.transition_matrix(dt) @ state_k
    for tau in (0.1, 0.25, 0.4):
        lam, psi = gp_prior.interpolation_matrices(tau, dt)
        np.testing.assert_allclose(lam @ state_k + psi @ state_kp1, gp_prior.transition_matrix(tau) @ state_k,
                                   atol=1e-12)


def test_interpolated_position_is_the_cubic_hermite_spline():
    # The WNOA posterior mean between two support states is the cubic Hermite interpolant.
    rng = np.random.default_rng(6)
    dt = 0.8
    state_k, state_kp1 = rng.normal(size=4), rng.normal(size=4)
    for tau in (0.1, 0.35, 0.6):
        lam, psi = gp_prior.interpolation_matrices(tau, dt)
        s = tau / dt
        h00, h10, h01, h11 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s, -2 * s**3 + 3 * s**2, s**3 - s**2
        hermite = h00 * state_k[:2] + h10 * dt * state_k[2:] + h01 * state_kp1[:2] + h11 * dt * state_kp1[2:]
        np.testing.assert_allclose((lam @ state_k + psi @ state_kp1)[:2], hermite, atol=1e-12)


def test_interpolate_states_inserts_points_in_time_order():
    states = np.array([[0.0, 0.0, 1.0, 0.0], [1.0, 0.0, 1.0, 0.0], [2.0, 0.0, 1.0, 0.0]])
    dense = gp_prior.interpolate_states(states, 1.0, 3)
    assert dense.shape == (9, 4)
    np.testing.assert_allclose(dense[:, 0], np.linspace(0.0, 2.0, 9), atol=1e-12)
    np.testing.assert_array_equal(dense[::4], states)


@pytest.mark.parametrize('call, message', [
    (lambda: gp_prior.process_covariance(0.0, 1.0), 'dt: must be finite and > 0'),
    (lambda: gp_prior.process_covariance(0.1, [1.0, -1.0]), 'qc: every power-spectral density'),
    (lambda: gp_prior.process_information(float('nan'), 1.0), 'dt: must be finite'),
    (lambda: gp_prior.interpolation_matrices(0.6, 0.5), r'tau: must be within \[0, dt=0.5\]'),
])
def test_bad_arguments_name_the_argument(call, message):
    with pytest.raises(ValueError, match=message):
        call()

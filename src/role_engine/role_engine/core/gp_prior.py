"""Constant-velocity Gaussian-process prior of a process role (paper Eq. 16-19).

A support state is ``[x, y, vx, vy]`` (Eq. 16: position and velocity of one robot in the
plane). The white-noise-on-acceleration model (Eq. 17, 18) gives, for a step ``dt``, the
transition ``Phi`` and the process covariance ``Q`` of Eq. 19, with ``Q_c`` the diagonal
power-spectral density (one entry per axis).

The prior error between consecutive support states uses gtsam's ``WnoaMotionFactorPoint2``
sign convention, ``e = x_{k+1} - Phi(dt) x_k``, so that ``0.5 * e^T Q^-1 e`` is exactly that
factor's error; the GP prior cost of a trajectory is the sum over its intervals (Eq. 8, 11).

Everything here is plain numpy and shared by both planner formulations (gtsam graph and
vectorised least squares) and by the tests that check gtsam's factor against Eq. 19.
"""
from __future__ import annotations

import functools

import numpy as np

from .errors import RoleEngineError

#: Length of one support state [x, y, vx, vy] (Eq. 16).
STATE_DIM = 4
#: Length of the position (and of the velocity) part of a state.
POSITION_DIM = 2


def _psd_diagonal(qc: float | np.ndarray) -> np.ndarray:
    """``Q_c`` as its diagonal of length 2 (a scalar means the same density on both axes)."""
    diagonal = np.broadcast_to(np.asarray(qc, dtype=float), (POSITION_DIM,)).copy()
    if not np.all(np.isfinite(diagonal)) or np.any(diagonal <= 0.0):
        raise RoleEngineError(f'qc: every power-spectral density entry must be finite and > 0 (got {diagonal})')
    return diagonal


def _check_dt(dt: float) -> float:
    dt = float(dt)
    if not np.isfinite(dt) or dt <= 0.0:
        raise RoleEngineError(f'dt: must be finite and > 0 (got {dt})')
    return dt


def transition_matrix(dt: float) -> np.ndarray:
    """State transition ``Phi(t, s)`` for ``t - s = dt`` (Eq. 19), shape (4, 4)."""
    dt = float(dt)
    eye = np.eye(POSITION_DIM)
    phi = np.eye(STATE_DIM)
    phi[:POSITION_DIM, POSITION_DIM:] = dt * eye
    return phi


def process_covariance(dt: float, qc: float | np.ndarray) -> np.ndarray:
    """Process noise ``Q_{k,k+1}`` of one interval (Eq. 19), shape (4, 4)."""
    dt = _check_dt(dt)
    qc_matrix = np.diag(_psd_diagonal(qc))
    return np.block([[dt ** 3 / 3.0 * qc_matrix, dt ** 2 / 2.0 * qc_matrix],
                     [dt ** 2 / 2.0 * qc_matrix, dt * qc_matrix]])


def process_information(dt: float, qc: float | np.ndarray) -> np.ndarray:
    """``Q^-1`` in closed form (inverse of the 2x2 block pattern of Eq. 19), shape (4, 4)."""
    dt = _check_dt(dt)
    qc_inverse = np.diag(1.0 / _psd_diagonal(qc))
    return np.block([[12.0 / dt ** 3 * qc_inverse, -6.0 / dt ** 2 * qc_inverse],
                     [-6.0 / dt ** 2 * qc_inverse, 4.0 / dt * qc_inverse]])


def whitening_matrix(dt: float, qc: float | np.ndarray) -> np.ndarray:
    """Upper-triangular ``W`` with ``W^T W = Q^-1``: ``||W e||^2`` is the Mahalanobis norm of Eq. 8.

    It is the square-root information matrix gtsam's Gaussian noise model uses, so whitened
    prior errors are the same numbers in both formulations.
    """
    lower = np.linalg.cholesky(process_information(dt, qc))
    return lower.T


def prior_error(state_k: np.ndarray, state_kp1: np.ndarray, dt: float) -> np.ndarray:
    """GP prior error ``x_{k+1} - Phi(dt) x_k`` of one interval (Eq. 19), shape (4,)."""
    return np.asarray(state_kp1, dtype=float) - transition_matrix(dt) @ np.asarray(state_k, dtype=float)


def prior_jacobians(dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Jacobians of :func:`prior_error` with respect to ``x_k`` and ``x_{k+1}``: ``(-Phi, I)``."""
    return -transition_matrix(dt), np.eye(STATE_DIM)


def prior_errors(states: np.ndarray, dt: float) -> np.ndarray:
    """Prior errors of every interval of a trajectory (N+1, 4) at once, shape (N, 4)."""
    states = np.asarray(states, dtype=float)
    errors = states[1:] - states[:-1]
    errors[:, :POSITION_DIM] -= dt * states[:-1, POSITION_DIM:]
    return errors


def prior_cost(states: np.ndarray, dt: float, qc: float | np.ndarray) -> float:
    """GP prior cost ``0.5 * sum_k e_k^T Q^-1 e_k`` (Eq. 8 over the support intervals)."""
    whitened = prior_errors(states, dt) @ whitening_matrix(dt, qc).T
    return 0.5 * float(np.sum(whitened ** 2))


def interpolation_matrices(tau: float, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """``(Lambda, Psi)`` with ``x(t_k + tau) = Lambda x_k + Psi x_{k+1}`` (GP posterior mean).

    Conditioning the LTV-SDE solution (Eq. 6, 7) on both bordering support states gives
    ``Psi = Q_tau Phi(dt - tau)^T Q_dt^-1`` and ``Lambda = Phi(tau) - Psi Phi(dt)``
    (Barfoot et al.; GPMP2's interpolation). ``Q_c`` cancels because every block of Eq. 19 is a
    scalar times ``Q_c``, so it is not an argument. ``0 <= tau <= dt``.
    """
    dt = _check_dt(dt)
    tau = float(tau)
    if not 0.0 <= tau <= dt:
        raise RoleEngineError(f'tau: must be within [0, dt={dt}] (got {tau})')
    if tau == 0.0:
        return np.eye(STATE_DIM), np.zeros((STATE_DIM, STATE_DIM))
    unit_psd = np.ones(POSITION_DIM)
    psi = process_covariance(tau, unit_psd) @ transition_matrix(dt - tau).T @ process_information(dt, unit_psd)
    lam = transition_matrix(tau) - psi @ transition_matrix(dt)
    return lam, psi


def interpolation_stack(count: int, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``count`` evenly spaced interior instants of one interval and their matrices.

    Returns ``taus (count,)``, ``Lambdas (count, 4, 4)`` and ``Psis (count, 4, 4)`` for
    ``tau_i = (i + 1) dt / (count + 1)``.
    """
    return _interpolation_stack(int(count), float(dt))


@functools.lru_cache(maxsize=64)
def _interpolation_stack(count: int, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`interpolation_stack`, computed once per (count, dt): every plan and clearance check of a
    planner asks for the same matrices. The arrays are read-only (they are shared)."""
    taus = dt * np.arange(1, count + 1) / (count + 1)
    pairs = [interpolation_matrices(tau, dt) for tau in taus]
    lambdas = np.array([pair[0] for pair in pairs]).reshape(count, STATE_DIM, STATE_DIM)
    psis = np.array([pair[1] for pair in pairs]).reshape(count, STATE_DIM, STATE_DIM)
    for array in (taus, lambdas, psis):
        array.setflags(write=False)
    return taus, lambdas, psis


def interpolate_states(states: np.ndarray, dt: float, count: int) -> np.ndarray:
    """The support states with ``count`` GP-interpolated states inserted in every interval.

    Returns ``(N * (count + 1) + 1, 4)`` states in time order.
    """
    states = np.asarray(states, dtype=float)
    if count == 0:
        return states.copy()
    _, lambdas, psis = interpolation_stack(count, dt)
    inner = (np.einsum('cij,kj->kci', lambdas, states[:-1])
             + np.einsum('cij,kj->kci', psis, states[1:]))             # (N, count, 4)
    blocks = np.concatenate([states[:-1, None, :], inner], axis=1)     # (N, count + 1, 4)
    return np.concatenate([blocks.reshape(-1, STATE_DIM), states[-1:]], axis=0)

"""Vectorised formulation of GP inference: numpy residuals, banded normal equations, own LM.

Every :class:`~.gp_costs.CostTerm` is evaluated for all its factors in one numpy call; the
Gauss-Newton system ``J^T J`` is accumulated straight into LAPACK's symmetric band storage
(factors only couple consecutive support states, so the half bandwidth is 7 for 4-D states)
and solved with ``scipy.linalg.solveh_banded``. A term that couples distant states widens the
band; past :data:`MAX_BAND` the system is solved as a sparse matrix instead.

:func:`levenberg_marquardt` reproduces gtsam's ``LevenbergMarquardtOptimizer`` (4.3, default
parameters: ``lambda I`` damping, fixed lambda factor, model-fidelity test, the same stopping
rules), so both formulations take the same steps and reach the same cost on the same problem.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg
import scipy.sparse
import scipy.sparse.linalg

from .gp_costs import CostTerm
from .gp_prior import STATE_DIM

#: Widest half bandwidth solved in band storage; wider systems use a sparse solver.
MAX_BAND = 64


@dataclass(frozen=True)
class LMSettings:
    """Levenberg-Marquardt parameters, named and defaulted as in gtsam's ``LevenbergMarquardtParams``.

    The paper stops "if a maximum iteration is reached or if the relative decrease in error is
    smaller than a threshold" (Sec. IV); ``absolute_error_tol`` defaults to 0 (gtsam's is 1e-5)
    so that only the relative rule decides, whatever the scale of the cost.
    """

    max_iterations: int = 100
    relative_error_tol: float = 1e-5
    absolute_error_tol: float = 0.0
    lambda_initial: float = 1e-5
    lambda_factor: float = 10.0
    lambda_upper_bound: float = 1e5
    lambda_lower_bound: float = 0.0
    min_model_fidelity: float = 1e-3


@dataclass
class SolveOutcome:
    """What a formulation's optimiser returns."""

    trajectory: np.ndarray          # (N+1, 4) optimised support states
    cost: float                     # 0.5 * sum of squared whitened errors at ``trajectory``
    initial_cost: float
    iterations: int                 # accepted LM steps (gtsam's ``iterations()``)
    converged: bool                 # stopped by a tolerance rather than by ``max_iterations``
    cost_history: list[float] = field(default_factory=list)   # cost after each outer iteration


def converged_by_tolerance(settings: LMSettings, previous_error: float, new_error: float,
                           error_tol: float = 0.0) -> bool:
    """gtsam's ``checkConvergence`` (relative or absolute decrease, or error below ``error_tol``)."""
    if new_error <= error_tol:
        return True
    decrease = previous_error - new_error
    relative = decrease / previous_error
    return bool((settings.relative_error_tol and relative <= settings.relative_error_tol)
                or decrease <= settings.absolute_error_tol)


class _TermLayout:
    """Global column indices and band-storage scatter indices of one term's factors."""

    def __init__(self, term: CostTerm, variable_count: int):
        local = np.arange(STATE_DIM)
        # (M, 4 s): global variable index of each local Jacobian column.
        self.columns = (term.state_indices[:, :, None] * STATE_DIM + local).reshape(term.factor_count, -1)
        rows_global = self.columns[:, :, None]
        cols_global = self.columns[:, None, :]
        self.lower_mask = np.broadcast_to(rows_global >= cols_global,
                                          (term.factor_count,) + (self.columns.shape[1],) * 2)
        offsets = (rows_global - cols_global)
        # Lower band storage ab[i - j, j] flattened as (i - j) * n + j.
        flat = offsets * variable_count + np.broadcast_to(cols_global, offsets.shape)
        self.band_index = flat[self.lower_mask]
        self.sparse_rows = np.broadcast_to(rows_global, offsets.shape).reshape(-1)
        self.sparse_cols = np.broadcast_to(cols_global, offsets.shape).reshape(-1)


@dataclass
class _Linearization:
    cost: float
    gradient: np.ndarray                          # J^T r, (n,)
    hessian_band: np.ndarray | None               # lower band storage of J^T J
    hessian_sparse: scipy.sparse.csc_matrix | None
    blocks: list[tuple[np.ndarray, np.ndarray]]   # per term: whitened residuals, Jacobians


class VectorisedProblem:
    """Sum-of-squares problem over the flattened support states (N+1) * 4."""

    def __init__(self, terms: list[CostTerm], state_count: int):
        self.terms = list(terms)
        self.state_count = int(state_count)
        self.variable_count = self.state_count * STATE_DIM
        spans = [int(np.max(t.state_indices.max(axis=1) - t.state_indices.min(axis=1)))
                 for t in self.terms if t.factor_count]
        self.band = (max(spans, default=0) + 1) * STATE_DIM - 1
        self.banded = self.band <= MAX_BAND
        self._layouts = [_TermLayout(t, self.variable_count) for t in self.terms]

    def cost(self, states: np.ndarray) -> float:
        return sum(term.cost(states) for term in self.terms)

    def linearize(self, states: np.ndarray) -> _Linearization:
        n = self.variable_count
        gradient = np.zeros(n)
        band_values: list[np.ndarray] = []
        band_indices: list[np.ndarray] = []
        sparse_values: list[np.ndarray] = []
        blocks = []
        cost = 0.0
        for term, layout in zip(self.terms, self._layouts):
            residuals, jacobians = term.evaluate(states)
            blocks.append((residuals, jacobians))
            cost += 0.5 * float(np.sum(residuals ** 2))
            gradient += np.bincount(layout.columns.reshape(-1),
                                    weights=np.einsum('mrc,mr->mc', jacobians, residuals).reshape(-1),
                                    minlength=n)
            local_hessians = np.einsum('mri,mrj->mij', jacobians, jacobians)
            if self.banded:
                band_values.append(local_hessians[layout.lower_mask])
                band_indices.append(layout.band_index)
            else:
                sparse_values.append(local_hessians.reshape(-1))
        if self.banded:
            flat = np.bincount(np.concatenate(band_indices), weights=np.concatenate(band_values),
                               minlength=(self.band + 1) * n)
            return _Linearization(cost, gradient, flat.reshape(self.band + 1, n), None, blocks)
        rows = np.concatenate([layout.sparse_rows for layout in self._layouts])
        cols = np.concatenate([layout.sparse_cols for layout in self._layouts])
        hessian = scipy.sparse.coo_matrix((np.concatenate(sparse_values), (rows, cols)), shape=(n, n)).tocsc()
        return _Linearization(cost, gradient, None, hessian, blocks)

    def solve_damped(self, linear: _Linearization, damping: float) -> np.ndarray | None:
        """``(J^T J + damping I) delta = -J^T r``; None if the system is not positive definite."""
        try:
            if linear.hessian_band is not None:
                damped = linear.hessian_band.copy()
                damped[0] += damping
                delta = scipy.linalg.solveh_banded(damped, -linear.gradient, lower=True, check_finite=False)
            else:
                damped = linear.hessian_sparse + damping * scipy.sparse.identity(self.variable_count, format='csc')
                delta = scipy.sparse.linalg.spsolve(damped, -linear.gradient)
        except (np.linalg.LinAlgError, ValueError):
            return None
        return delta if np.all(np.isfinite(delta)) else None

    def linearized_cost(self, linear: _Linearization, delta: np.ndarray) -> float:
        """``0.5 * ||r + J delta||^2`` summed over terms (gtsam's ``linear.error(delta)``)."""
        total = 0.0
        for (residuals, jacobians), layout in zip(linear.blocks, self._layouts):
            predicted = residuals + np.einsum('mrc,mc->mr', jacobians, delta[layout.columns])
            total += 0.5 * float(np.sum(predicted ** 2))
        return total


def levenberg_marquardt(problem: VectorisedProblem, initial: np.ndarray, settings: LMSettings) -> SolveOutcome:
    """Minimise ``problem`` from ``initial`` (N+1, 4) with gtsam's LM rules (see module docstring)."""
    values = np.array(initial, dtype=float).reshape(-1)
    shape = (problem.state_count, STATE_DIM)
    error = problem.cost(values.reshape(shape))
    initial_error = error
    history: list[float] = []
    iterations = 0
    converged = error <= 0.0
    lam = settings.lambda_initial
    if converged or settings.max_iterations <= 0:
        return SolveOutcome(values.reshape(shape), error, initial_error, 0, converged, history)
    new_error = error
    while True:
        current_error = new_error
        linear = problem.linearize(values.reshape(shape))
        while True:                                           # gtsam's tryLambda loop
            step_successful = False
            stop_searching = False
            delta = problem.solve_damped(linear, lam)
            if delta is not None:
                old_linearized = linear.cost
                linearized_change = old_linearized - problem.linearized_cost(linear, delta)
                if linearized_change >= 0.0:
                    trial = values + delta
                    trial_error = problem.cost(trial.reshape(shape))
                    cost_change = error - trial_error
                    if linearized_change > np.finfo(float).eps * old_linearized:
                        step_successful = cost_change / linearized_change > settings.min_model_fidelity
                    if abs(cost_change) < settings.relative_error_tol * error:
                        stop_searching = True
            if step_successful:
                values, error = trial, trial_error
                lam = max(settings.lambda_lower_bound, lam / settings.lambda_factor)
                iterations += 1
                break
            if stop_searching:
                break
            lam *= settings.lambda_factor
            if lam >= settings.lambda_upper_bound:
                break
        new_error = error
        history.append(new_error)
        converged = converged_by_tolerance(settings, current_error, new_error)
        if iterations >= settings.max_iterations or converged or not math.isfinite(current_error):
            break
    return SolveOutcome(values.reshape(shape), new_error, initial_error, iterations, converged, history)

"""gtsam formulation of GP inference: a factor graph solved by ``LevenbergMarquardtOptimizer``.

Each support state k is two gtsam variables, position ``X(k)`` and velocity ``V(k)`` (both
``Point2``), as ``WnoaMotionFactorPoint2`` expects. Terms become factors:

* :class:`~.gp_costs.GPPriorTerm` -> gtsam's native ``WnoaMotionFactorPoint2`` (its error is
  ``[p2 - p1 - dt v1, v2 - v1]`` with covariance Q of Eq. 19, checked in the unit tests);
* :class:`~.gp_costs.StatePriorTerm` -> two ``PriorFactorPoint2`` (position, velocity);
* every other term -> one ``gtsam.CustomFactor`` per factor whose Python callback calls the
  term's own numpy :meth:`~.gp_costs.CostTerm.errors`, so the cost is the vectorised one.

The graph can be reused for incremental re-planning (``gtsam.ISAM2.update`` accepts it), and a
re-plan warm-starts by passing the previous solution as the initial values.
"""
from __future__ import annotations

from typing import Callable

import gtsam
import numpy as np
from gtsam.symbol_shorthand import V, X

from .gp_costs import CostTerm, GPPriorTerm, StatePriorTerm
from .gp_prior import POSITION_DIM, STATE_DIM
from .gp_vectorised import LMSettings, SolveOutcome, converged_by_tolerance


def position_key(index: int) -> int:
    return X(int(index))


def velocity_key(index: int) -> int:
    return V(int(index))


def values_from_states(states: np.ndarray) -> gtsam.Values:
    """gtsam values of support states (N+1, 4)."""
    values = gtsam.Values()
    for index, state in enumerate(np.asarray(states, dtype=float)):
        values.insert(position_key(index), np.ascontiguousarray(state[:POSITION_DIM]))
        values.insert(velocity_key(index), np.ascontiguousarray(state[POSITION_DIM:]))
    return values


def states_from_values(values: gtsam.Values, state_count: int) -> np.ndarray:
    """Support states (N+1, 4) read back from gtsam values."""
    return np.array([np.concatenate([values.atPoint2(position_key(k)), values.atPoint2(velocity_key(k))])
                     for k in range(state_count)])


def _noise_model(sqrt_information: np.ndarray) -> gtsam.noiseModel.Base:
    diagonal = np.diag(sqrt_information)
    if np.all(sqrt_information == np.diag(diagonal)):
        return gtsam.noiseModel.Diagonal.Sigmas(1.0 / diagonal)
    return gtsam.noiseModel.Gaussian.SqrtInformation(sqrt_information)


def _custom_error(term: CostTerm, factor_id: int) -> Callable:
    """The CustomFactor callback of factor ``factor_id`` of ``term``."""
    indices = [int(i) for i in term.state_indices[factor_id]]
    ids = np.array([factor_id])
    position_columns = [slice(STATE_DIM * q, STATE_DIM * q + POSITION_DIM) for q in range(len(indices))]
    velocity_columns = [slice(STATE_DIM * q + POSITION_DIM, STATE_DIM * (q + 1)) for q in range(len(indices))]
    blocks = []            # Jacobian column block of each gtsam key, in key order
    for q in range(len(indices)):
        if term.uses_position:
            blocks.append(position_columns[q])
        if term.uses_velocity:
            blocks.append(velocity_columns[q])

    def error(_factor: gtsam.CustomFactor, values: gtsam.Values, jacobians) -> np.ndarray:
        local = np.zeros((1, len(indices), STATE_DIM))
        for q, index in enumerate(indices):
            if term.uses_position:
                local[0, q, :POSITION_DIM] = values.atPoint2(position_key(index))
            if term.uses_velocity:
                local[0, q, POSITION_DIM:] = values.atPoint2(velocity_key(index))
        errors, local_jacobians = term.errors(local, ids, jacobians is not None)
        if jacobians is not None:
            for slot, columns in enumerate(blocks):
                jacobians[slot] = np.ascontiguousarray(local_jacobians[0][:, columns])
        return errors[0]

    return error


def _custom_keys(term: CostTerm, factor_id: int) -> list[int]:
    keys = []
    for index in term.state_indices[factor_id]:
        if term.uses_position:
            keys.append(position_key(index))
        if term.uses_velocity:
            keys.append(velocity_key(index))
    return keys


def term_factors(term: CostTerm) -> list[gtsam.NonlinearFactor]:
    """gtsam factors equivalent to ``term`` (native where gtsam has one, else CustomFactor)."""
    if isinstance(term, GPPriorTerm):
        qc = np.asarray(term.qc, dtype=float)
        return [gtsam.WnoaMotionFactorPoint2(
            gtsam.StateData(position_key(k), velocity_key(k), k * term.dt),
            gtsam.StateData(position_key(k1), velocity_key(k1), k1 * term.dt), qc)
            for k, k1 in term.state_indices]
    if isinstance(term, StatePriorTerm):
        (index,), = term.state_indices
        return [gtsam.PriorFactorPoint2(position_key(index), term.target[:POSITION_DIM],
                                        gtsam.noiseModel.Isotropic.Sigma(POSITION_DIM, term.sigma_position)),
                gtsam.PriorFactorPoint2(velocity_key(index), term.target[POSITION_DIM:],
                                        gtsam.noiseModel.Isotropic.Sigma(POSITION_DIM, term.sigma_velocity))]
    noise = _noise_model(term.sqrt_information)
    return [gtsam.CustomFactor(noise, _custom_keys(term, j), _custom_error(term, j))
            for j in range(term.factor_count)]


def build_graph(terms: list[CostTerm]) -> gtsam.NonlinearFactorGraph:
    graph = gtsam.NonlinearFactorGraph()
    for term in terms:
        for factor in term_factors(term):
            graph.add(factor)
    return graph


def lm_params(settings: LMSettings) -> gtsam.LevenbergMarquardtParams:
    """gtsam LM parameters for ``settings`` (``minModelFidelity`` is gtsam's default, 1e-3)."""
    params = gtsam.LevenbergMarquardtParams()
    params.setMaxIterations(settings.max_iterations)
    params.setRelativeErrorTol(settings.relative_error_tol)
    params.setAbsoluteErrorTol(settings.absolute_error_tol)
    params.setErrorTol(0.0)
    params.setlambdaInitial(settings.lambda_initial)
    params.setlambdaFactor(settings.lambda_factor)
    params.setlambdaUpperBound(settings.lambda_upper_bound)
    params.setlambdaLowerBound(settings.lambda_lower_bound)
    return params


def optimise(terms: list[CostTerm], initial: np.ndarray, settings: LMSettings) -> SolveOutcome:
    """Build the graph of ``terms`` and run gtsam's LM from ``initial`` (N+1, 4)."""
    state_count = int(np.asarray(initial).shape[0])
    graph = build_graph(terms)
    values = values_from_states(initial)
    initial_cost = graph.error(values)
    params = lm_params(settings)
    history: list[float] = []
    last_errors = [initial_cost, initial_cost]

    def record(_iteration: int, error_before: float, error_after: float) -> None:
        history.append(error_after)
        last_errors[:] = [error_before, error_after]

    params.iterationHook = record
    optimizer = gtsam.LevenbergMarquardtOptimizer(graph, values, params)
    result = optimizer.optimize()
    cost = graph.error(result)
    converged = cost <= 0.0 or (bool(history) and converged_by_tolerance(settings, *last_errors))
    return SolveOutcome(states_from_values(result, state_count), cost, initial_cost,
                        int(optimizer.iterations()), converged, history)

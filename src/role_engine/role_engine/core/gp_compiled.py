"""Compiled formulation of GP inference: the cost terms packed into arrays, a numba LM (:mod:`.gp_kernels`).

The third back end of the same :class:`~.gp_costs.CostTerm` objects (after the vectorised numpy
one and the gtsam graph). Each term kind the kernels know is packed by a function registered in
:data:`PACKERS` under the term's exact class (a subclass may redefine ``errors``, so it is not
assumed to be its parent): its factors become rows of the kernels' *linear* table (GP prior,
start / goal priors: ``e = A [x_k; x_k+1] - c``, whitened by ``W``) or *hinge* table (obstacles
on the SDF, other robots, the speed limit; see :mod:`.gp_kernels`). The parameters are read from
the term (its ``sqrt_information``, transition, interpolation maps, radii, epsilons), so both
back ends evaluate the one cost the term defines.

:func:`compile_problem` returns None (and :func:`unsupported_reason` says why) when a problem has
a term kind no packer knows, obstacle terms on an SDF that is not a grid
:class:`~.sdf.SignedDistanceField` (an analytic field has no kernel), several different SDFs, or
factors that couple other than consecutive states; the planner then runs the vectorised
formulation instead, which reaches the same cost.

The kernels are compiled on first use and cached on disk by numba (``cache=True``: in
``__pycache__`` next to this file, or numba's user-wide cache directory when that is read-only);
:func:`warm_up` loads (or compiles) them so a node does it at start, not in its first re-plan.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from . import gp_kernels
from .errors import RoleEngineError
from .gp_costs import (CostTerm, GPPriorTerm, InterpolatedMovingObstacleTerm, InterpolatedObstacleTerm,
                       MovingObstacleTerm, ObstacleTerm, StatePriorTerm, VelocityLimitTerm)
from .gp_prior import POSITION_DIM, STATE_DIM, transition_matrix
from .gp_vectorised import LMSettings, SolveOutcome
from .sdf import SignedDistanceField

_POSITION_ROWS = np.hstack([np.eye(POSITION_DIM), np.zeros((POSITION_DIM, POSITION_DIM + STATE_DIM))])  # (2, 8)
_VELOCITY_ROWS = np.hstack([np.zeros((POSITION_DIM, POSITION_DIM)), np.eye(POSITION_DIM),
                            np.zeros((POSITION_DIM, STATE_DIM))])


@dataclass
class _Linear:
    """Rows of the linear table: states (m,), (m,) (-1: one state), A (m, 4, 8), c (m, 4), W (m, 4, 4)."""

    i0: np.ndarray
    i1: np.ndarray
    a: np.ndarray
    c: np.ndarray
    w: np.ndarray


@dataclass
class _Hinge:
    """Rows of the hinge table (see :mod:`.gp_kernels`)."""

    i0: np.ndarray
    i1: np.ndarray
    maps: np.ndarray            # (m, 2, 8)
    kind: int
    points: np.ndarray          # (m, 2)
    offset: float
    epsilon: float
    weight: float
    sdf: SignedDistanceField | None = None


def _tile(matrix: np.ndarray, count: int) -> np.ndarray:
    return np.ascontiguousarray(np.broadcast_to(matrix, (count,) + matrix.shape))


def _scalar_weight(term: CostTerm) -> float:
    weight = np.asarray(term.sqrt_information, dtype=float)
    if weight.shape != (1, 1):
        raise _Unsupported(f'{term.name}: sqrt_information must be 1 x 1 (got {weight.shape})')
    return float(weight[0, 0])


def _pairs(term: CostTerm) -> tuple[np.ndarray, np.ndarray]:
    indices = np.asarray(term.state_indices, dtype=np.int64)
    if indices.ndim != 2 or indices.shape[1] != 2 or np.any(indices[:, 1] != indices[:, 0] + 1):
        raise _Unsupported(f'{term.name}: factors must read two consecutive states')
    return indices[:, 0].copy(), indices[:, 1].copy()


def _singles(term: CostTerm) -> tuple[np.ndarray, np.ndarray]:
    indices = np.asarray(term.state_indices, dtype=np.int64)
    if indices.ndim != 2 or indices.shape[1] != 1:
        raise _Unsupported(f'{term.name}: factors must read one state')
    return indices[:, 0].copy(), np.full(indices.shape[0], -1, dtype=np.int64)


def _pack_gp_prior(term: GPPriorTerm) -> _Linear:
    i0, i1 = _pairs(term)
    jacobian = np.hstack([-transition_matrix(term.dt), np.eye(STATE_DIM)])      # e = x_k+1 - Phi x_k
    return _Linear(i0, i1, _tile(jacobian, i0.size), np.zeros((i0.size, STATE_DIM)),
                   _tile(np.asarray(term.sqrt_information, dtype=float), i0.size))


def _pack_state_prior(term: StatePriorTerm) -> _Linear:
    i0, i1 = _singles(term)
    jacobian = np.hstack([np.eye(STATE_DIM), np.zeros((STATE_DIM, STATE_DIM))])  # e = x - target
    return _Linear(i0, i1, _tile(jacobian, i0.size), _tile(term.target, i0.size),
                   _tile(np.asarray(term.sqrt_information, dtype=float), i0.size))


def _interpolated_maps(term) -> np.ndarray:
    return term._position_map[np.arange(term.factor_count) % term.count]


def _pack_obstacle(term: ObstacleTerm) -> _Hinge:
    i0, i1 = _singles(term)
    return _Hinge(i0, i1, _tile(_POSITION_ROWS, i0.size), gp_kernels.KIND_SDF, np.zeros((i0.size, 2)),
                  term.robot_radius, term.epsilon, _scalar_weight(term), term.sdf)


def _pack_interpolated_obstacle(term: InterpolatedObstacleTerm) -> _Hinge:
    i0, i1 = _pairs(term)
    return _Hinge(i0, i1, _interpolated_maps(term), gp_kernels.KIND_SDF, np.zeros((i0.size, 2)),
                  term.robot_radius, term.epsilon, _scalar_weight(term), term.sdf)


def _pack_velocity_limit(term: VelocityLimitTerm) -> _Hinge:
    i0, i1 = _singles(term)
    return _Hinge(i0, i1, _tile(_VELOCITY_ROWS, i0.size), gp_kernels.KIND_SPEED, np.zeros((i0.size, 2)),
                  term.max_speed, 0.0, _scalar_weight(term))


def _pack_moving_obstacle(term: MovingObstacleTerm) -> _Hinge:
    i0, i1 = _singles(term)
    return _Hinge(i0, i1, _tile(_POSITION_ROWS, i0.size), gp_kernels.KIND_POINT, term.positions,
                  term.combined_radius, term.epsilon, _scalar_weight(term))


def _pack_interpolated_moving_obstacle(term: InterpolatedMovingObstacleTerm) -> _Hinge:
    i0, i1 = _pairs(term)
    return _Hinge(i0, i1, _interpolated_maps(term), gp_kernels.KIND_POINT, term.positions,
                  term.combined_radius, term.epsilon, _scalar_weight(term))


#: Packer of each term class the kernels evaluate (exact classes, see the module docstring).
PACKERS: dict[type, Callable[[CostTerm], _Linear | _Hinge]] = {
    GPPriorTerm: _pack_gp_prior,
    StatePriorTerm: _pack_state_prior,
    ObstacleTerm: _pack_obstacle,
    InterpolatedObstacleTerm: _pack_interpolated_obstacle,
    VelocityLimitTerm: _pack_velocity_limit,
    MovingObstacleTerm: _pack_moving_obstacle,
    InterpolatedMovingObstacleTerm: _pack_interpolated_moving_obstacle,
}


class _Unsupported(Exception):
    pass


def _concat(parts: list[np.ndarray], shape: tuple[int, ...], dtype=float) -> np.ndarray:
    if not parts:
        return np.zeros((0,) + shape, dtype=dtype)
    return np.ascontiguousarray(np.concatenate(parts), dtype=dtype)


class CompiledProblem:
    """The packed factor tables of one problem, in term order; ``slices`` maps each term to its rows."""

    def __init__(self, terms: list[CostTerm], state_count: int):
        self.terms = list(terms)
        self.state_count = int(state_count)
        linear: list[_Linear] = []
        hinge: list[_Hinge] = []
        self.slices: list[tuple[str, bool, slice]] = []      # (name, linear?, rows)
        sdf = None
        for term in self.terms:
            packer = PACKERS.get(type(term))
            if packer is None:
                raise _Unsupported(f'{term.name}: no compiled form for {type(term).__name__}')
            packed = packer(term)
            if isinstance(packed, _Linear):
                start = sum(p.i0.size for p in linear)
                linear.append(packed)
                self.slices.append((term.name, True, slice(start, start + packed.i0.size)))
                continue
            if packed.kind == gp_kernels.KIND_SDF and packed.i0.size:
                if type(packed.sdf) is not SignedDistanceField:
                    raise _Unsupported(f'{term.name}: the SDF is a {type(packed.sdf).__name__}, not a grid '
                                       f'SignedDistanceField')
                if sdf is not None and packed.sdf is not sdf:
                    raise _Unsupported(f'{term.name}: obstacle terms on different SDFs')
                sdf = packed.sdf
            start = sum(p.i0.size for p in hinge)
            hinge.append(packed)
            self.slices.append((term.name, False, slice(start, start + packed.i0.size)))
        indices = [p.i0 for p in linear + hinge] + [p.i1 for p in linear + hinge]
        if indices and (max(int(i.max(initial=-1)) for i in indices) >= self.state_count
                        or min(int(i.min(initial=0)) for i in indices) < -1):
            raise _Unsupported(f'state indices must lie in [0, {self.state_count - 1}]')
        self.lin_i0 = _concat([p.i0 for p in linear], (), np.int64)
        self.lin_i1 = _concat([p.i1 for p in linear], (), np.int64)
        self.lin_a = _concat([p.a for p in linear], (STATE_DIM, 2 * STATE_DIM))
        self.lin_c = _concat([p.c for p in linear], (STATE_DIM,))
        self.lin_w = _concat([p.w for p in linear], (STATE_DIM, STATE_DIM))
        self.lin_j = np.ascontiguousarray(np.einsum('mij,mjk->mik', self.lin_w, self.lin_a))
        count = [p.i0.size for p in hinge]
        self.hin_i0 = _concat([p.i0 for p in hinge], (), np.int64)
        self.hin_i1 = _concat([p.i1 for p in hinge], (), np.int64)
        self.hin_map = _concat([p.maps for p in hinge], (POSITION_DIM, 2 * STATE_DIM))
        self.hin_kind = _concat([np.full(n, p.kind) for n, p in zip(count, hinge)], (), np.int64)
        self.hin_point = _concat([p.points for p in hinge], (POSITION_DIM,))
        self.hin_offset = _concat([np.full(n, p.offset) for n, p in zip(count, hinge)], ())
        self.hin_eps = _concat([np.full(n, p.epsilon) for n, p in zip(count, hinge)], ())
        self.hin_w = _concat([np.full(n, p.weight) for n, p in zip(count, hinge)], ())
        if sdf is None:
            self.grid, self.origin, self.resolution = np.zeros((1, 1)), (0.0, 0.0), 1.0
        else:
            self.grid = np.ascontiguousarray(sdf.data, dtype=float)
            self.origin, self.resolution = (float(sdf.origin[0]), float(sdf.origin[1])), float(sdf.resolution)

    def _tables(self) -> tuple:
        return (self.lin_i0, self.lin_i1, self.lin_a, self.lin_c, self.lin_w)

    def _hinges(self) -> tuple:
        return (self.hin_i0, self.hin_i1, self.hin_map, self.hin_kind, self.hin_point, self.hin_offset,
                self.hin_eps, self.hin_w, self.grid, self.origin[0], self.origin[1], self.resolution)

    def evaluate(self, states: np.ndarray) -> tuple[float, np.ndarray, np.ndarray, np.ndarray]:
        """Cost, whitened linear residuals (L, 4), hinge residuals (H,) and hinge Jacobians (H, 8)."""
        states = np.ascontiguousarray(states, dtype=float)
        r_lin = np.empty((self.lin_i0.size, STATE_DIM))
        r_hin = np.empty(self.hin_i0.size)
        j_hin = np.empty((self.hin_i0.size, 2 * STATE_DIM))
        cost, status = gp_kernels.evaluate(states, *self._tables(), *self._hinges(), r_lin, r_hin, j_hin)
        _check_status(status)
        return cost, r_lin, r_hin, j_hin

    def term_costs(self, r_lin: np.ndarray, r_hin: np.ndarray) -> dict[str, float]:
        """``0.5 * sum r^2`` per term name from the packed residuals (as :func:`.gp_costs.term_costs`)."""
        costs: dict[str, float] = {}
        for name, linear, rows in self.slices:
            residuals = r_lin[rows] if linear else r_hin[rows]
            costs[name] = costs.get(name, 0.0) + 0.5 * float(np.sum(residuals ** 2))
        return costs


def _check_status(status: int) -> None:
    if status == gp_kernels.STATUS_NONFINITE_POINT:
        raise RoleEngineError('sdf.query points: every coordinate must be finite')


def compile_problem(terms: list[CostTerm], state_count: int) -> CompiledProblem | None:
    """The packed problem, or None when the compiled back end cannot take it (module docstring)."""
    try:
        return CompiledProblem(terms, state_count)
    except _Unsupported:
        return None


def unsupported_reason(terms: list[CostTerm], state_count: int) -> str | None:
    """Why :func:`compile_problem` returns None for these terms (None if it does not)."""
    try:
        CompiledProblem(terms, state_count)
    except _Unsupported as error:
        return str(error)
    return None


@dataclass
class CompiledOutcome(SolveOutcome):
    """A :class:`~.gp_vectorised.SolveOutcome` plus the final cost split by term name."""

    term_costs: dict[str, float] | None = None


def optimise(problem: CompiledProblem, initial: np.ndarray, settings: LMSettings) -> CompiledOutcome:
    """Run the compiled LM from ``initial`` (N+1, 4) with ``settings`` (gtsam's rules)."""
    states = np.ascontiguousarray(initial, dtype=float)
    if states.shape != (problem.state_count, STATE_DIM):
        raise RoleEngineError(f'initial: must have shape ({problem.state_count}, 4) (got {states.shape})')
    (values, cost, initial_cost, iterations, converged, history, count, status,
     r_lin, r_hin) = gp_kernels.levenberg_marquardt(
        states, *problem._tables(), problem.lin_j, *problem._hinges(), int(settings.max_iterations),
        float(settings.relative_error_tol), float(settings.absolute_error_tol), float(settings.lambda_initial),
        float(settings.lambda_factor), float(settings.lambda_upper_bound), float(settings.lambda_lower_bound),
        float(settings.min_model_fidelity))
    _check_status(status)
    return CompiledOutcome(values, float(cost), float(initial_cost), int(iterations), bool(converged),
                           [float(v) for v in history[:count]], problem.term_costs(r_lin, r_hin))


_WARM = False


def warm_up() -> float:
    """Load (or compile and cache) the kernels with a tiny problem of every factor kind; idempotent.

    Returns the seconds it took (0 when the kernels were ready): about 0.2 s from numba's cache,
    5-20 s when it compiles (after an install or an edit of :mod:`.gp_kernels`).
    """
    global _WARM
    if _WARM:
        return 0.0
    began = time.perf_counter()
    sdf = SignedDistanceField(np.array([[0.3, 0.2, 0.3], [0.2, -0.1, 0.2], [0.3, 0.2, 0.3]]), 1.0, (-1.5, -1.5))
    line = np.column_stack([np.linspace(-1.0, 1.0, 3), np.zeros(3), np.full(3, 0.5), np.zeros(3)])
    terms = [GPPriorTerm(3, 2.0, np.ones(2)), StatePriorTerm('start', 0, line[0], 1e-2, 1e-2),
             ObstacleTerm(sdf, 3, 0.2, 0.1), InterpolatedObstacleTerm(sdf, 3, 2.0, 1, 0.2, 0.1),
             VelocityLimitTerm(3, 0.3, 0.1), MovingObstacleTerm(np.zeros((1, 2)), [1], 0.2, 0.1, 0.1)]
    optimise(CompiledProblem(terms, 3), line, LMSettings(max_iterations=2))
    _WARM = True
    return time.perf_counter() - began

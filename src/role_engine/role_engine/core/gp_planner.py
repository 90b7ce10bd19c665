"""GP inference of one process role (paper Sec. II-B, IV; Eq. 11 solved by Levenberg-Marquardt).

:class:`GPPlanner` optimises a trajectory of support states ``[x, y, vx, vy]`` (N+1, 4) spread
evenly over ``total_time``, starting from an initial trajectory (the E-Map initial path, or
the previous solution when re-planning: that is the warm start). The cost is

* the constant-velocity GP prior (Eq. 16-19),
* the obstacle hinge likelihood on the SDF minus the robot radius, with safety distance
  ``epsilon`` and ``sigma_obs`` (Eq. 20, 21), at the support states and optionally at
  ``obstacle_interpolation`` GP-interpolated instants per interval,
* motion constraints (Eq. 22): tight priors on the start and goal states and an optional
  speed limit,
* any extra :class:`~.gp_costs.CostTerm` the caller adds, e.g.
  :class:`~.gp_costs.MovingObstacleTerm` for other robots' shared process roles.

Three formulations minimise the same cost with the same LM rules: ``'compiled'`` (the terms
packed into arrays, residuals and Jacobians in one pass, block-tridiagonal normal equations and
the whole LM loop in numba; :mod:`.gp_compiled`, :mod:`.gp_kernels`), ``'vectorised'`` (numpy,
banded normal equations; :mod:`.gp_vectorised`) and ``'gtsam'`` (factor graph with
``WnoaMotionFactorPoint2`` and ``CustomFactor``; :mod:`.gp_gtsam`, the reference).
``scripts/bench gpmp`` (:mod:`role_engine.experiments.benchmark`) times the three on identical
problems and compares their final costs. The compiled one is the default (the role player's
re-plans, the engine's evaluations, the tables); a problem it cannot take (a term kind without
a compiled form, an analytic SDF) runs the vectorised formulation instead, and the result's
``formulation`` says which one ran. The gtsam graph stays available for ISAM2.

Choices where the paper is silent: sigmas are standard deviations (GPMP2's convention);
the start and goal states default to the first and last rows of the initial trajectory; a
plan is ``collision_free`` when the SDF minus the robot radius is >= 0 at every support state
and at ``collision_check_interpolation`` GP-interpolated instants per interval (the centre
does not touch an inflated obstacle; the paper's failure criterion), while ``min_clearance``
lets a caller also demand the safety distance ``epsilon``.
"""
from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import Any, Iterable, Mapping, Sequence

import numpy as np

from . import gp_compiled, gp_gtsam
from .errors import RoleEngineError, check_count, check_real
from .gp_costs import (CostTerm, GPPriorTerm, InterpolatedObstacleTerm, ObstacleTerm, SignedDistanceQuery,
                       StatePriorTerm, VelocityLimitTerm, query_sdf, term_costs)
from .gp_prior import POSITION_DIM, STATE_DIM, interpolate_states
from .gp_vectorised import LMSettings, SolveOutcome, VectorisedProblem, levenberg_marquardt

#: Formulations :meth:`GPPlanner.plan` can use.
FORMULATIONS = ('vectorised', 'gtsam', 'compiled')


def _fail(path: str, message: str) -> RoleEngineError:
    return RoleEngineError(f'{path}: {message}')


@dataclass(frozen=True)
class GPPlannerConfig:
    """Parameters of GP inference; every field is validated on construction (ValueError).

    Units: metres, seconds. Sigmas are standard deviations of the whitened errors.
    """

    #: Power-spectral density Q_c of the white-noise acceleration (Eq. 5, 19): one value or (qx, qy).
    qc: float | tuple[float, float] = 1.0
    #: Standard deviation of the obstacle hinge error (Sigma_obs = sigma_obs I, Eq. 9, 21).
    sigma_obs: float = 0.1
    #: Safety distance epsilon of the hinge loss (Eq. 21) [m].
    epsilon: float = 0.1
    #: Radius of the robot's bounding sphere, subtracted from the SDF (Sec. IV-B) [m].
    robot_radius: float = 0.0
    #: Extra obstacle factors at GP-interpolated instants inside each interval (0 = support states only).
    obstacle_interpolation: int = 0
    #: Speed limit of Eq. 22 [m/s]; None disables the velocity-limit factors.
    max_speed: float | None = None
    #: Standard deviation of the speed-limit error (sigma_c of Eq. 22) [m/s].
    sigma_velocity: float = 0.01
    #: Start / goal constraints (Eq. 22): standard deviations of position [m] and velocity [m/s].
    sigma_start_position: float = 1e-4
    sigma_start_velocity: float = 1e-4
    sigma_goal_position: float = 1e-4
    sigma_goal_velocity: float = 1e-4
    #: Levenberg-Marquardt: iteration cap and relative-decrease stop (Sec. IV).
    max_iterations: int = 100
    relative_error_tol: float = 1e-5
    #: Initial LM damping. gtsam's default 1e-5 makes the first step almost Gauss-Newton, which can
    #: jump support states across a thin wall; GPMP2's planners (the paper's library) start at 1000.
    lambda_initial: float = 1e-5
    #: GP-interpolated instants per interval also checked by ``collision_free`` / ``min_clearance``.
    collision_check_interpolation: int = 4
    #: 'compiled' (numba), 'vectorised' (numpy) or 'gtsam' (the reference).
    formulation: str = 'compiled'

    def __post_init__(self) -> None:
        path = type(self).__name__
        qc = self.qc
        if isinstance(qc, (list, tuple, np.ndarray)):
            if len(qc) != POSITION_DIM:
                raise _fail(f'{path}.qc', f'must be one number or two (qx, qy) (got {len(qc)} values)')
            qc_pair = tuple(check_real(q, f'{path}.qc[{i}]', positive=True) for i, q in enumerate(qc))
        else:
            value = check_real(qc, f'{path}.qc', positive=True)
            qc_pair = (value, value)
        object.__setattr__(self, 'qc', qc_pair)
        for name in ('sigma_obs', 'sigma_velocity', 'sigma_start_position', 'sigma_start_velocity',
                     'sigma_goal_position', 'sigma_goal_velocity'):
            check_real(getattr(self, name), f'{path}.{name}', positive=True)
        for name in ('epsilon', 'robot_radius'):
            check_real(getattr(self, name), f'{path}.{name}', non_negative=True)
        if self.max_speed is not None:
            check_real(self.max_speed, f'{path}.max_speed', positive=True)
        check_real(self.relative_error_tol, f'{path}.relative_error_tol', non_negative=True)
        check_real(self.lambda_initial, f'{path}.lambda_initial', positive=True)
        check_count(self.obstacle_interpolation, f'{path}.obstacle_interpolation', minimum=0)
        check_count(self.collision_check_interpolation, f'{path}.collision_check_interpolation', minimum=0)
        check_count(self.max_iterations, f'{path}.max_iterations', minimum=1)
        if self.formulation not in FORMULATIONS:
            raise _fail(f'{path}.formulation', f'must be one of {", ".join(FORMULATIONS)} (got {self.formulation!r})')

    @classmethod
    def from_mapping(cls, mapping: Mapping[str, Any], path: str = 'gp') -> 'GPPlannerConfig':
        """Build from a YAML / ROS-parameter mapping; unknown keys are errors (``path.key: ...``)."""
        if not isinstance(mapping, Mapping):
            raise _fail(path, f'must be a mapping (got {type(mapping).__name__})')
        names = [f.name for f in fields(cls)]
        unknown = sorted(set(mapping) - set(names))
        if unknown:
            raise _fail(f'{path}.{unknown[0]}', f'unknown key (allowed: {", ".join(names)})')
        try:
            return cls(**dict(mapping))
        except ValueError as error:
            raise RoleEngineError(str(error).replace(f'{cls.__name__}.', f'{path}.', 1)) from None

    @property
    def lm_settings(self) -> LMSettings:
        return LMSettings(max_iterations=self.max_iterations, relative_error_tol=self.relative_error_tol,
                          lambda_initial=self.lambda_initial)


@dataclass
class GPPlanResult:
    """An optimised process role and how it was obtained."""

    trajectory: np.ndarray          # (N+1, 4) support states [x, y, vx, vy]
    times: np.ndarray               # (N+1,) support times, 0 .. total_time
    cost: float                     # 0.5 * sum of squared whitened errors (= gtsam graph.error)
    initial_cost: float
    term_costs: dict[str, float]    # the cost split by term name (e.g. gp_prior vs obstacle, Eq. 13)
    iterations: int                 # accepted LM steps
    converged: bool                 # stopped by the relative-decrease rule (or no decrease left), not the cap
    min_clearance: float            # min of SDF - robot radius over the checked instants [m]
    collision_free: bool            # min_clearance >= 0
    formulation: str
    cost_history: list[float] = field(default_factory=list)

    @property
    def dt(self) -> float:
        return float(self.times[1] - self.times[0])


class GPPlanner:
    """Optimises process roles against one robot type's SDF (see the module docstring)."""

    def __init__(self, config: GPPlannerConfig, sdf: SignedDistanceQuery):
        if not isinstance(config, GPPlannerConfig):
            raise RoleEngineError(f'config: must be a GPPlannerConfig (got {type(config).__name__})')
        if not callable(getattr(sdf, 'query', None)):
            raise RoleEngineError(f'sdf: must have a query(points) -> (distance, gradient) method '
                                  f'(got {type(sdf).__name__})')
        self.config = config
        self.sdf = sdf

    def terms(self, state_count: int, total_time: float, start: np.ndarray, goal: np.ndarray,
              extra_terms: Sequence[CostTerm] = ()) -> list[CostTerm]:
        """The cost terms of one problem, shared by every formulation."""
        cfg = self.config
        dt = total_time / (state_count - 1)
        terms: list[CostTerm] = [
            GPPriorTerm(state_count, dt, np.array(cfg.qc)),
            StatePriorTerm('start', 0, start, cfg.sigma_start_position, cfg.sigma_start_velocity),
            StatePriorTerm('goal', state_count - 1, goal, cfg.sigma_goal_position, cfg.sigma_goal_velocity),
            ObstacleTerm(self.sdf, state_count, cfg.epsilon, cfg.sigma_obs, cfg.robot_radius),
        ]
        if cfg.obstacle_interpolation > 0:
            terms.append(InterpolatedObstacleTerm(self.sdf, state_count, dt, cfg.obstacle_interpolation,
                                                  cfg.epsilon, cfg.sigma_obs, cfg.robot_radius))
        if cfg.max_speed is not None:
            terms.append(VelocityLimitTerm(state_count, cfg.max_speed, cfg.sigma_velocity))
        terms.extend(extra_terms)
        return terms

    def plan(self, initial: np.ndarray, total_time: float, *, start: np.ndarray | None = None,
             goal: np.ndarray | None = None, extra_terms: Iterable[CostTerm] = (),
             formulation: str | None = None) -> GPPlanResult:
        """Optimise ``initial`` (N+1, 4) spanning ``total_time`` seconds.

        ``start`` / ``goal`` (4,) default to the first / last initial state. Pass the previous
        result's trajectory as ``initial`` to warm-start a re-plan (e.g. with a new ``start``
        from tracking and new ``extra_terms`` from the shared channel).
        """
        formulation = self.config.formulation if formulation is None else formulation
        if formulation not in FORMULATIONS:
            raise _fail('formulation', f'must be one of {", ".join(FORMULATIONS)} (got {formulation!r})')
        states, total_time, start, goal, extra = self._check_problem(initial, total_time, start, goal, extra_terms)
        terms = self.terms(states.shape[0], total_time, start, goal, extra)
        compiled = gp_compiled.compile_problem(terms, states.shape[0]) if formulation == 'compiled' else None
        if formulation == 'gtsam':
            outcome = gp_gtsam.optimise(terms, states, self.config.lm_settings)
        elif compiled is not None:
            outcome = gp_compiled.optimise(compiled, states, self.config.lm_settings)
        else:
            formulation = 'vectorised'
            outcome = levenberg_marquardt(VectorisedProblem(terms, states.shape[0]), states,
                                          self.config.lm_settings)
        return self._result(outcome, terms, total_time, formulation)

    def evaluate(self, trajectory: np.ndarray, total_time: float, *, start: np.ndarray | None = None,
                 goal: np.ndarray | None = None, extra_terms: Iterable[CostTerm] = ()) -> dict[str, float]:
        """Cost of a given trajectory split by term, without optimising (e.g. for Eq. 13)."""
        states, total_time, start, goal, extra = self._check_problem(trajectory, total_time, start, goal,
                                                                     extra_terms)
        return term_costs(self.terms(states.shape[0], total_time, start, goal, extra), states)

    def clearance(self, trajectory: np.ndarray, total_time: float) -> float:
        """Min of SDF - robot radius at the support states and the collision-check instants."""
        states = np.asarray(trajectory, dtype=float)
        dt = total_time / (states.shape[0] - 1)
        dense = interpolate_states(states, dt, self.config.collision_check_interpolation)
        distance, _ = query_sdf(self.sdf, np.ascontiguousarray(dense[:, :POSITION_DIM]))
        return float(np.min(distance) - self.config.robot_radius)

    def _result(self, outcome: SolveOutcome, terms: list[CostTerm], total_time: float,
                formulation: str) -> GPPlanResult:
        state_count = outcome.trajectory.shape[0]
        clearance = self.clearance(outcome.trajectory, total_time)
        return GPPlanResult(
            trajectory=outcome.trajectory, times=np.linspace(0.0, total_time, state_count),
            cost=outcome.cost, initial_cost=outcome.initial_cost,
            term_costs=getattr(outcome, 'term_costs', None) or term_costs(terms, outcome.trajectory),
            iterations=outcome.iterations, converged=outcome.converged,
            min_clearance=clearance, collision_free=clearance >= 0.0,
            formulation=formulation, cost_history=outcome.cost_history)

    def _check_problem(self, initial, total_time, start, goal, extra_terms):
        states = _check_states(initial, 'initial')
        total_time = check_real(total_time, 'total_time', positive=True)
        start = states[0].copy() if start is None else _check_state(start, 'start')
        goal = states[-1].copy() if goal is None else _check_state(goal, 'goal')
        extra = list(extra_terms)
        for index, term in enumerate(extra):
            path = f'extra_terms[{index}]'
            if not isinstance(term, CostTerm):
                raise _fail(path, f'must be a CostTerm (got {type(term).__name__})')
            if term.factor_count and (term.state_indices.min() < 0 or term.state_indices.max() >= states.shape[0]):
                raise _fail(f'{path}.state_indices', f'must lie in [0, {states.shape[0] - 1}] '
                                                     f'(got {term.state_indices.min()}..{term.state_indices.max()})')
        return states, total_time, start, goal, extra


def _check_states(value: Any, path: str) -> np.ndarray:
    try:
        states = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise _fail(path, 'must be a numeric array of shape (N+1, 4)') from None
    if states.ndim != 2 or states.shape[1] != STATE_DIM or states.shape[0] < 2:
        raise _fail(path, f'must have shape (N+1, 4) with N+1 >= 2 states [x, y, vx, vy] (got {states.shape})')
    if not np.all(np.isfinite(states)):
        bad = np.argwhere(~np.isfinite(states))[0]
        raise _fail(f'{path}[{bad[0]}, {bad[1]}]', f'must be finite (got {states[tuple(bad)]})')
    return states


def _check_state(value: Any, path: str) -> np.ndarray:
    try:
        state = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise _fail(path, 'must be a numeric state [x, y, vx, vy]') from None
    if state.shape != (STATE_DIM,):
        raise _fail(path, f'must have shape (4,) [x, y, vx, vy] (got {state.shape})')
    if not np.all(np.isfinite(state)):
        raise _fail(path, f'must be finite (got {state})')
    return state

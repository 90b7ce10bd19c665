"""Cost terms of GP inference for one process role (paper Eq. 9, 11, 19-22).

The MAP problem (Eq. 11) is a sum of squared whitened errors. Each :class:`CostTerm` holds
one kind of factor, many instances at once: ``state_indices[j]`` lists the support states
factor ``j`` reads, :meth:`CostTerm.errors` returns unwhitened errors and their Jacobians for
any batch of factors, and ``sqrt_information`` whitens them (``W^T W = Sigma^-1``). Both
planner formulations consume the same terms:

* the vectorised one evaluates every factor of a term in one numpy call;
* the gtsam one wraps each factor in a ``CustomFactor`` (or a native gtsam factor where one
  exists: ``WnoaMotionFactorPoint2`` for the prior, ``PriorFactorPoint2`` for state priors),

so the cost ``0.5 * sum ||W e||^2`` has one definition. A new term (for example the conflict
cost of other robots' process roles, Eq. 10) only has to implement :meth:`CostTerm.errors` to
work in both formulations.

Sigmas are standard deviations, as in GPMP2 (the library the paper used): the paper's
``Sigma_obs = sigma_obs I`` is read as ``sigma_obs`` being the standard deviation of the
hinge residual.
"""
from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Protocol

import numpy as np

from .errors import RoleEngineError
from .gp_prior import POSITION_DIM, STATE_DIM, interpolation_stack, transition_matrix, whitening_matrix


class SignedDistanceQuery(Protocol):
    """What the planner needs from a signed distance field (world metres).

    ``query(points (n, 2)) -> (distance (n,), gradient (n, 2))``; distance is negative inside
    obstacles, gradient is d distance / d point.
    """

    def query(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]: ...


def query_sdf(sdf: SignedDistanceQuery, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Query ``sdf`` and check its answer, so a faulty field fails with a clear message."""
    distance, gradient = sdf.query(points)
    distance = np.asarray(distance, dtype=float)
    gradient = np.asarray(gradient, dtype=float)
    count = points.shape[0]
    if distance.shape != (count,) or gradient.shape != (count, POSITION_DIM):
        raise RoleEngineError(f'sdf.query: must return distance ({count},) and gradient ({count}, 2) '
                              f'(got {distance.shape} and {gradient.shape})')
    if not (np.all(np.isfinite(distance)) and np.all(np.isfinite(gradient))):
        raise RoleEngineError('sdf.query: returned non-finite distances or gradients')
    return distance, gradient


def hinge_loss(distance: np.ndarray, epsilon: float) -> tuple[np.ndarray, np.ndarray]:
    """Hinge loss ``c(z)`` of Eq. 21 and its derivative with respect to the distance.

    ``c = epsilon - d`` where ``d <= epsilon``, else 0. At the kink ``d == epsilon`` the value
    is 0 and the derivative is the left one, -1 (GPMP2's convention), so a state sitting on
    the safety boundary is still pushed outwards.
    """
    distance = np.asarray(distance, dtype=float)
    active = distance <= epsilon
    return np.where(active, epsilon - distance, 0.0), np.where(active, -1.0, 0.0)


def term_costs(terms: list['CostTerm'], states: np.ndarray) -> dict[str, float]:
    """Cost of each term on ``states`` (N+1, 4), summed by term name."""
    costs: dict[str, float] = {}
    for term in terms:
        costs[term.name] = costs.get(term.name, 0.0) + term.cost(states)
    return costs


class CostTerm(ABC):
    """A batch of factors of one kind; see the module docstring."""

    #: Short name, used in the per-term cost breakdown of a plan.
    name: str
    #: (M, s) support-state indices read by each of the M factors.
    state_indices: np.ndarray
    #: Length of one factor's error.
    residual_dim: int
    #: Whether errors depend on the position / velocity half of a state (selects gtsam keys).
    uses_position: bool = True
    uses_velocity: bool = False
    #: (r, r) upper-triangular square-root information ``W`` (``W^T W = Sigma^-1``).
    sqrt_information: np.ndarray

    @abstractmethod
    def errors(self, local_states: np.ndarray, factor_ids: np.ndarray,
               with_jacobians: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
        """Unwhitened errors of the factors ``factor_ids``.

        ``local_states`` is (m, s, 4): the states ``state_indices[factor_ids]``. Returns errors
        (m, r) and, if asked, Jacobians (m, r, 4 s) with respect to those states (column
        ``4 q + c`` is component ``c`` of the q-th state the factor reads).
        """

    @property
    def factor_count(self) -> int:
        return int(self.state_indices.shape[0])

    def evaluate(self, states: np.ndarray, with_jacobians: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
        """Whitened errors (M, r) and Jacobians (M, r, 4 s) of every factor on ``states`` (N+1, 4)."""
        local = states[self.state_indices]
        errors, jacobians = self.errors(local, np.arange(self.factor_count), with_jacobians)
        weight = self.sqrt_information
        scale = self._diagonal_weight()
        if scale is not None:
            errors = errors * scale
            if jacobians is not None:
                jacobians = jacobians * scale[None, :, None]
        else:
            errors = errors @ weight.T
            if jacobians is not None:
                jacobians = np.einsum('ij,mjk->mik', weight, jacobians)
        return errors, jacobians

    def _diagonal_weight(self) -> np.ndarray | None:
        """diag(W) when W is diagonal (a cheap scaling instead of a matrix product), else None.

        Computed once: ``sqrt_information`` is fixed when a term is constructed.
        """
        if not hasattr(self, '_diagonal_scale'):
            weight = self.sqrt_information
            self._diagonal_scale = np.diag(weight).copy() if _is_diagonal(weight) else None
        return self._diagonal_scale

    def cost(self, states: np.ndarray) -> float:
        """``0.5 * sum ||W e||^2`` over this term's factors."""
        whitened, _ = self.evaluate(states, with_jacobians=False)
        return 0.5 * float(np.sum(whitened ** 2))


def _is_diagonal(matrix: np.ndarray) -> bool:
    return bool(np.all(matrix == np.diag(np.diag(matrix))))


def _isotropic_weight(dim: int, sigma: float) -> np.ndarray:
    return np.eye(dim) / float(sigma)


class GPPriorTerm(CostTerm):
    """Constant-velocity GP prior between consecutive support states (Eq. 8, 19)."""

    residual_dim = STATE_DIM
    uses_velocity = True

    def __init__(self, state_count: int, dt: float, qc: np.ndarray, name: str = 'gp_prior'):
        self.name = name
        self.dt = float(dt)
        self.qc = np.asarray(qc, dtype=float)
        self.state_indices = np.stack([np.arange(state_count - 1), np.arange(1, state_count)], axis=1)
        self.sqrt_information = whitening_matrix(self.dt, self.qc)
        self._jacobian = np.hstack([-transition_matrix(self.dt), np.eye(STATE_DIM)])

    def errors(self, local_states, factor_ids, with_jacobians=True):
        state_k, state_kp1 = local_states[:, 0], local_states[:, 1]
        errors = state_kp1 - state_k
        errors[:, :POSITION_DIM] -= self.dt * state_k[:, POSITION_DIM:]       # x_{k+1} - Phi x_k
        if not with_jacobians:
            return errors, None
        return errors, np.broadcast_to(self._jacobian, (len(factor_ids),) + self._jacobian.shape)


class StatePriorTerm(CostTerm):
    """Start or goal constraint: a tight Gaussian prior on one support state (Eq. 22)."""

    residual_dim = STATE_DIM
    uses_velocity = True

    def __init__(self, name: str, state_index: int, target: np.ndarray,
                 sigma_position: float, sigma_velocity: float):
        self.name = name
        self.target = np.asarray(target, dtype=float).reshape(STATE_DIM)
        self.sigma_position = float(sigma_position)
        self.sigma_velocity = float(sigma_velocity)
        self.state_indices = np.array([[state_index]])
        self.sqrt_information = np.diag(1.0 / np.array([sigma_position] * POSITION_DIM
                                                       + [sigma_velocity] * POSITION_DIM))

    def errors(self, local_states, factor_ids, with_jacobians=True):
        errors = local_states[:, 0] - self.target
        if not with_jacobians:
            return errors, None
        return errors, np.broadcast_to(np.eye(STATE_DIM), (len(factor_ids), STATE_DIM, STATE_DIM))


class ObstacleTerm(CostTerm):
    """Obstacle likelihood at every support state: hinge of the SDF minus the robot radius (Eq. 20, 21)."""

    residual_dim = 1

    def __init__(self, sdf: SignedDistanceQuery, state_count: int, epsilon: float, sigma: float,
                 robot_radius: float = 0.0, name: str = 'obstacle'):
        self.name = name
        self.sdf = sdf
        self.epsilon = float(epsilon)
        self.robot_radius = float(robot_radius)
        self.state_indices = np.arange(state_count)[:, None]
        self.sqrt_information = _isotropic_weight(1, sigma)

    def errors(self, local_states, factor_ids, with_jacobians=True):
        distance, gradient = query_sdf(self.sdf, local_states[:, 0, :POSITION_DIM])
        cost, slope = hinge_loss(distance - self.robot_radius, self.epsilon)
        if not with_jacobians:
            return cost[:, None], None
        jacobians = np.zeros((len(factor_ids), 1, STATE_DIM))
        jacobians[:, 0, :POSITION_DIM] = slope[:, None] * gradient
        return cost[:, None], jacobians


class InterpolatedObstacleTerm(CostTerm):
    """Obstacle likelihood at ``count`` GP-interpolated instants inside every interval (GPMP2's
    interpolated obstacle factor), so thin obstacles between support states are seen too."""

    residual_dim = 1
    uses_velocity = True

    def __init__(self, sdf: SignedDistanceQuery, state_count: int, dt: float, count: int,
                 epsilon: float, sigma: float, robot_radius: float = 0.0,
                 name: str = 'obstacle_interpolated'):
        self.name = name
        self.sdf = sdf
        self.count = int(count)
        self.epsilon = float(epsilon)
        self.robot_radius = float(robot_radius)
        interval = np.repeat(np.arange(state_count - 1), self.count)
        self.state_indices = np.stack([interval, interval + 1], axis=1)
        self.sqrt_information = _isotropic_weight(1, sigma)
        _, lambdas, psis = interpolation_stack(self.count, dt)
        # Position rows only: (count, 2, 8) maps [x_k, x_{k+1}] to the interpolated position.
        self._position_map = np.concatenate([lambdas[:, :POSITION_DIM], psis[:, :POSITION_DIM]], axis=2)

    def errors(self, local_states, factor_ids, with_jacobians=True):
        maps = self._position_map[np.asarray(factor_ids) % self.count]           # (m, 2, 8)
        positions = np.einsum('mpc,mc->mp', maps, local_states.reshape(len(factor_ids), 2 * STATE_DIM))
        distance, gradient = query_sdf(self.sdf, positions)
        cost, slope = hinge_loss(distance - self.robot_radius, self.epsilon)
        if not with_jacobians:
            return cost[:, None], None
        jacobians = np.einsum('mp,mpc->mc', slope[:, None] * gradient, maps)[:, None, :]
        return cost[:, None], jacobians


class VelocityLimitTerm(CostTerm):
    """Speed limit as a motion constraint (Eq. 22): error ``max(0, |v| - v_max)`` per state.

    The paper's penalty is "the difference between the current velocity and maximum
    velocity"; a mobile robot's limit is on its linear speed, so the norm is used rather than
    per-axis limits. Like the obstacle hinge, the factor is active on the boundary
    ``|v| = v_max`` (error 0, gradient ``v / |v|``).
    """

    residual_dim = 1
    uses_position = False
    uses_velocity = True

    def __init__(self, state_count: int, max_speed: float, sigma: float, name: str = 'velocity_limit'):
        self.name = name
        self.max_speed = float(max_speed)
        self.state_indices = np.arange(state_count)[:, None]
        self.sqrt_information = _isotropic_weight(1, sigma)

    def errors(self, local_states, factor_ids, with_jacobians=True):
        velocity = local_states[:, 0, POSITION_DIM:]
        speed = np.linalg.norm(velocity, axis=1)
        active = speed >= self.max_speed
        errors = np.where(active, speed - self.max_speed, 0.0)[:, None]
        if not with_jacobians:
            return errors, None
        jacobians = np.zeros((len(factor_ids), 1, STATE_DIM))
        safe_speed = np.where(active, speed, 1.0)
        jacobians[:, 0, POSITION_DIM:] = np.where(active[:, None], velocity / safe_speed[:, None], 0.0)
        return errors, jacobians


class MovingObstacleTerm(CostTerm):
    """Other robots' time-indexed positions as moving obstacles (the shared-factor idea of Eq. 10).

    Factor ``j`` ties support state ``state_indices[j]`` to ``positions[j]``, where another
    robot is (or plans to be) at that state's time. The error is the hinge of Eq. 21 on the
    centre distance minus ``combined_radius`` (own radius + other radius) with safety distance
    ``epsilon`` (:func:`separation_hinge`).
    """

    residual_dim = 1

    def __init__(self, positions: np.ndarray, state_indices: np.ndarray, combined_radius: float,
                 epsilon: float, sigma: float, name: str = 'moving_obstacles'):
        positions = np.asarray(positions, dtype=float)
        indices = np.asarray(state_indices, dtype=int).reshape(-1)
        if positions.ndim != 2 or positions.shape != (indices.size, POSITION_DIM):
            raise RoleEngineError(f'{name}.positions: must have shape ({indices.size}, 2) to match state_indices '
                                  f'(got {positions.shape})')
        if not np.all(np.isfinite(positions)):
            raise RoleEngineError(f'{name}.positions: must be finite')
        _check_separation(name, combined_radius, epsilon, sigma)
        self.name = name
        self.positions = positions
        self.state_indices = indices[:, None]
        self.combined_radius = float(combined_radius)
        self.epsilon = float(epsilon)
        self.sqrt_information = _isotropic_weight(1, sigma)

    @classmethod
    def from_timed_positions(cls, times: np.ndarray, positions: np.ndarray, own_times: np.ndarray,
                             combined_radius: float, epsilon: float, sigma: float,
                             name: str = 'moving_obstacles') -> 'MovingObstacleTerm':
        """Resample another robot's shared trajectory (times (n,), positions (n, 2)) onto this
        plan's support times by linear interpolation. Before its first / after its last time
        the other robot is held at its first / last position (it waits, or has arrived)."""
        times = np.asarray(times, dtype=float).reshape(-1)
        positions = np.asarray(positions, dtype=float)
        if positions.shape != (times.size, POSITION_DIM) or times.size == 0:
            raise RoleEngineError(f'{name}: times (n,) and positions (n, 2) must match and be non-empty '
                                  f'(got {times.shape} and {positions.shape})')
        if np.any(np.diff(times) <= 0.0):
            raise RoleEngineError(f'{name}.times: must be strictly increasing')
        own_times = np.asarray(own_times, dtype=float).reshape(-1)
        resampled = np.stack([np.interp(own_times, times, positions[:, axis]) for axis in range(POSITION_DIM)],
                             axis=1)
        return cls(resampled, np.arange(own_times.size), combined_radius, epsilon, sigma, name)

    def errors(self, local_states, factor_ids, with_jacobians=True):
        cost, gradient = separation_hinge(local_states[:, 0, :POSITION_DIM] - self.positions[factor_ids],
                                          self.combined_radius, self.epsilon)
        if not with_jacobians:
            return cost[:, None], None
        jacobians = np.zeros((len(factor_ids), 1, STATE_DIM))
        jacobians[:, 0, :POSITION_DIM] = gradient
        return cost[:, None], jacobians


def separation_hinge(offset: np.ndarray, combined_radius: float, epsilon: float) -> tuple[np.ndarray, np.ndarray]:
    """Hinge (Eq. 21) on the centre distance ``|offset|`` minus ``combined_radius`` and its
    gradient (n, 2) with respect to the own position (``offset`` = own - other). At exactly
    coincident centres the push direction is +x (any unit vector would do)."""
    centre_distance = np.linalg.norm(offset, axis=1)
    cost, slope = hinge_loss(centre_distance - combined_radius, epsilon)
    direction = np.tile([1.0, 0.0], (len(offset), 1))
    apart = centre_distance > 0.0
    direction[apart] = offset[apart] / centre_distance[apart, None]
    return cost, slope[:, None] * direction


class InterpolatedMovingObstacleTerm(CostTerm):
    """Another robot as a moving obstacle at ``count`` GP-interpolated instants inside every interval.

    The companion of :class:`MovingObstacleTerm` (as :class:`InterpolatedObstacleTerm` is of
    :class:`ObstacleTerm`): two robots meeting head-on close at up to twice their speed, so
    between two support states they could pass *through* each other with every support state
    clear. Factor ``j`` reads interval ``j // count`` and compares the GP-interpolated own
    position at ``tau = (j % count + 1) dt / (count + 1)`` (Eq. 17-19, the same interpolation
    as the obstacle factors) with ``positions[j]``, where the other robot is at that instant.
    """

    residual_dim = 1
    uses_velocity = True

    def __init__(self, positions: np.ndarray, state_count: int, dt: float, count: int, combined_radius: float,
                 epsilon: float, sigma: float, name: str = 'moving_obstacles_interpolated'):
        if isinstance(count, bool) or not isinstance(count, (int, np.integer)) or count < 1:
            raise RoleEngineError(f'{name}.count: must be an integer >= 1 (got {count!r})')
        if not np.isfinite(dt) or dt <= 0.0:
            raise RoleEngineError(f'{name}.dt: must be finite and > 0 (got {dt})')
        intervals = int(state_count) - 1
        positions = np.asarray(positions, dtype=float)
        if positions.shape != (intervals * count, POSITION_DIM):
            raise RoleEngineError(f'{name}.positions: must have shape ({intervals * count}, 2) '
                                  f'(intervals x count) (got {positions.shape})')
        if not np.all(np.isfinite(positions)):
            raise RoleEngineError(f'{name}.positions: must be finite')
        _check_separation(name, combined_radius, epsilon, sigma)
        self.name = name
        self.positions = positions
        self.count = int(count)
        self.combined_radius = float(combined_radius)
        self.epsilon = float(epsilon)
        interval = np.repeat(np.arange(intervals), self.count)
        self.state_indices = np.stack([interval, interval + 1], axis=1)
        self.sqrt_information = _isotropic_weight(1, sigma)
        _, lambdas, psis = interpolation_stack(self.count, dt)
        self._position_map = np.concatenate([lambdas[:, :POSITION_DIM], psis[:, :POSITION_DIM]], axis=2)

    @staticmethod
    def instants(support_times: np.ndarray, count: int) -> np.ndarray:
        """The (N * count,) absolute times the factors compare at, for evenly spaced ``support_times``."""
        support_times = np.asarray(support_times, dtype=float)
        dt = support_times[1] - support_times[0]
        taus = dt * np.arange(1, count + 1) / (count + 1)
        return (support_times[:-1, None] + taus[None, :]).reshape(-1)

    def errors(self, local_states, factor_ids, with_jacobians=True):
        maps = self._position_map[np.asarray(factor_ids) % self.count]           # (m, 2, 8)
        own = np.einsum('mpc,mc->mp', maps, local_states.reshape(len(factor_ids), 2 * STATE_DIM))
        cost, gradient = separation_hinge(own - self.positions[factor_ids], self.combined_radius, self.epsilon)
        if not with_jacobians:
            return cost[:, None], None
        return cost[:, None], np.einsum('mp,mpc->mc', gradient, maps)[:, None, :]


def _check_separation(name: str, combined_radius: float, epsilon: float, sigma: float) -> None:
    for field, value in (('combined_radius', combined_radius), ('epsilon', epsilon)):
        if not np.isfinite(value) or value < 0.0:
            raise RoleEngineError(f'{name}.{field}: must be finite and >= 0 (got {value})')
    if not np.isfinite(sigma) or sigma <= 0.0:
        raise RoleEngineError(f'{name}.sigma: must be finite and > 0 (got {sigma})')

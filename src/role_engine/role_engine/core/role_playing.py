"""The role-playing update of one robot (Algorithm 4 lines 3-6): the others as moving obstacles.

Every re-plan robot j re-optimises the rest of its process role from its tracked position
(GP inference, :mod:`.gp_planner`). The others' process roles from the shared channel are
*time-indexed*: at each support time t_k of j's plan (and at ``interpolation`` GP-interpolated
instants inside each interval) a hinge factor (Eq. 21) on the distance between j's state at
t_k and robot i's role position at the same t_k keeps them ``r_i + r_j + clearance`` apart
(:class:`~.gp_costs.MovingObstacleTerm`, :class:`~.gp_costs.InterpolatedMovingObstacleTerm`).
Both planner formulations evaluate these terms (the gtsam one through ``CustomFactor``s), so
the cost is the same whichever ``GPPlannerConfig.formulation`` says.

Two robots meeting head-on start from a symmetric saddle: the straight line pushes straight
back and LM stays on it. So when the warm-started plan still conflicts, the update also
starts LM from *detour* initialisations -- the warm-start plan shifted sideways around the
first conflict by ``detour_scales`` x (r_i + r_j + clearance), to the right and to the left
of the relative motion -- and keeps the best result.

Where the paper is silent (it adds a conflict field to the SDF, Fig. 5; a static disc on
the other's path blocks a detour at every time, so the time-indexed form is used instead):

* every other robot's role counts over the whole remaining plan, not only the conflict
  horizon; the horizon only names the ``conflicting`` robots (as Fig. 5's field does);
  before its start / after its end a role holds its first / last position;
* choice among the optimised candidates: first those that keep every other robot at least
  ``r_i + r_j`` away at the checked instants and touch no static obstacle, then the lowest
  final cost; on a tie the earlier candidate wins, and the right-hand detour comes before
  the left one, so two robots that plan at the same time both keep right and still pass;
* the detour ramps in and out with a smoothstep over ``max(2 dt, 3 a / v)`` seconds
  (``a`` the offset, ``v`` the speed limit or 0.5 m/s), vanishing at the start and goal.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

from pybullet_bridge.core.fields import Fields

from .conflict import SharedRole, find_conflicts
from .environment import RobotEnvironment
from .errors import RoleEngineError
from .gp_costs import CostTerm, InterpolatedMovingObstacleTerm, MovingObstacleTerm
from .gp_planner import GPPlanner, GPPlannerConfig, GPPlanResult
from .trajectory import interpolate

#: Speed used to time a detour's ramps when the planner has no speed limit [m/s].
DEFAULT_DETOUR_SPEED = 0.5
#: Instants per interval at which separations between roles are measured (reports, choice).
SEPARATION_SAMPLES = 10


@dataclass(frozen=True)
class AvoidanceSettings:
    """How a role player keeps clear of the other robots' process roles (module docstring)."""

    #: Safety distance beyond r_i + r_j that the inter-robot hinge asks for [m], >= 0.
    clearance: float = 0.1
    #: Standard deviation of the inter-robot hinge residual [m], > 0 (smaller = stiffer).
    sigma: float = 0.02
    #: GP-interpolated instants per interval also compared with the others, >= 0.
    interpolation: int = 3
    #: Lateral detour offsets tried, in units of r_i + r_j + clearance; empty = warm start only.
    detour_scales: tuple[float, ...] = (1.0, 2.0)

    def __post_init__(self) -> None:
        for name, value, low in (('clearance', self.clearance, 0.0), ('sigma', self.sigma, None)):
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
                    or (value < 0.0 if low is not None else value <= 0.0):
                raise RoleEngineError(f"robot_avoidance.{name}: must be a finite number "
                                      f"{'>= 0' if low is not None else '> 0'} (got {value!r})")
        if isinstance(self.interpolation, bool) or not isinstance(self.interpolation, int) or self.interpolation < 0:
            raise RoleEngineError(f'robot_avoidance.interpolation: must be an integer >= 0 (got {self.interpolation!r})')
        scales = tuple(self.detour_scales)
        for index, scale in enumerate(scales):
            if isinstance(scale, bool) or not isinstance(scale, (int, float)) or not (math.isfinite(scale)
                                                                                      and scale > 0):
                raise RoleEngineError(f'robot_avoidance.detour_scales[{index}]: must be a finite number > 0 '
                                      f'(got {scale!r})')
        object.__setattr__(self, 'detour_scales', tuple(float(s) for s in scales))

    @classmethod
    def from_mapping(cls, data: Any, path: str = 'robot_avoidance') -> 'AvoidanceSettings':
        """From a settings-file mapping; unknown keys and bad values name ``path.field``."""
        fields = Fields(data if data is not None else {}, path,
                        allowed=('clearance', 'sigma', 'interpolation', 'detour_scales'))
        scales = fields.raw('detour_scales', list(cls.detour_scales))
        if not isinstance(scales, (list, tuple)):
            raise RoleEngineError(f'{path}.detour_scales: must be a list of numbers > 0 (got {scales!r})')
        try:
            return cls(clearance=fields.number('clearance', cls.clearance, ge=0.0),
                       sigma=fields.number('sigma', cls.sigma, gt=0.0),
                       interpolation=fields.integer('interpolation', cls.interpolation, ge=0),
                       detour_scales=tuple(scales))
        except RoleEngineError as error:
            raise RoleEngineError(str(error).replace('robot_avoidance', path, 1)) from None


@dataclass
class Replan:
    """A re-optimised process role starting at ``start_time`` (or why the old one is kept).

    ``min_gap`` is the smallest centre distance minus both radii between the new role and
    any other robot's role at the same instant (inf without others); ``initialisation``
    names the LM start that won ('warm start' or a detour).
    """

    trajectory: np.ndarray | None
    start_time: float
    total_time: float
    conflicting: list[str]
    reason: str = ''
    cost: float = math.nan
    min_gap: float = math.inf
    initialisation: str = ''
    candidates: int = 0
    term_costs: dict[str, float] = field(default_factory=dict)


def moving_obstacle_terms(own_radius: float, others: list[SharedRole], support_times: np.ndarray,
                          settings: AvoidanceSettings) -> list[CostTerm]:
    """Time-indexed hinge factors of every other role at the plan's absolute ``support_times``."""
    count = len(support_times)
    dt = float(support_times[1] - support_times[0])
    terms: list[CostTerm] = []
    for other in others:
        combined = own_radius + other.radius
        terms.append(MovingObstacleTerm(other.positions(support_times), np.arange(count), combined,
                                        settings.clearance, settings.sigma, name='robots'))
        if settings.interpolation:
            instants = InterpolatedMovingObstacleTerm.instants(support_times, settings.interpolation)
            terms.append(InterpolatedMovingObstacleTerm(other.positions(instants), count, dt,
                                                        settings.interpolation, combined, settings.clearance,
                                                        settings.sigma, name='robots_interpolated'))
    return terms


def role_gaps(trajectory: np.ndarray, start_time: float, total_time: float, own_radius: float,
              others: list[SharedRole], samples_per_interval: int = SEPARATION_SAMPLES) -> dict[str, float]:
    """Smallest centre distance minus both radii to each other role over ``[start, start + total]``."""
    times = start_time + np.linspace(0.0, total_time, (len(trajectory) - 1) * samples_per_interval + 1)
    own = interpolate(trajectory, total_time, times - start_time)[0]
    return {other.name: float(np.min(np.hypot(*(other.positions(times) - own).T)) - own_radius - other.radius)
            for other in others}


def _smoothstep(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def detour_initialisations(base: np.ndarray, relative_times: np.ndarray, own_radius: float, other: SharedRole,
                           start_time: float, settings: AvoidanceSettings,
                           speed: float) -> list[tuple[str, np.ndarray]]:
    """``base`` (N+1, 4) shifted sideways around its conflict with ``other`` (module docstring).

    The offset is perpendicular to the relative velocity at the closest approach (right
    first); when the two barely move relative to each other it points away from the other.
    Empty when ``base`` keeps ``r_i + r_j + clearance`` from ``other`` at every checked instant.
    """
    total = float(relative_times[-1])
    # Dense instants: a plan can pass through the other robot between two support states.
    dense = np.linspace(0.0, total, (len(base) - 1) * SEPARATION_SAMPLES + 1)
    own_positions, own_velocities, _ = interpolate(base, total, dense)
    other_positions = other.positions(start_time + dense)
    separation = own_radius + other.radius + settings.clearance
    gap = np.hypot(*(own_positions - other_positions).T) - separation
    close = np.flatnonzero(gap < 0.0)
    if close.size == 0:
        return []
    closest = int(np.argmin(gap))
    other_velocity = interpolate(other.trajectory, other.total_time,
                                 [start_time + dense[closest] - other.start_time])[1][0]
    relative_velocity = own_velocities[closest] - other_velocity
    away = own_positions[closest] - other_positions[closest]
    if np.linalg.norm(relative_velocity) > 1e-3:
        heading = relative_velocity / np.linalg.norm(relative_velocity)
        directions = [('right', np.array([heading[1], -heading[0]])), ('left', np.array([-heading[1], heading[0]]))]
    else:
        norm = np.linalg.norm(away)
        directions = [('away', away / norm if norm > 1e-9 else np.array([1.0, 0.0]))]
    t_first, t_last = dense[close[0]], dense[close[-1]]
    dt = relative_times[1] - relative_times[0]
    candidates = []
    for scale in settings.detour_scales:
        amplitude = scale * separation
        ramp = max(2.0 * dt, 3.0 * amplitude / speed)
        weight = np.minimum.reduce([
            _smoothstep((relative_times - (t_first - ramp)) / ramp),        # in before the conflict
            _smoothstep(((t_last + ramp) - relative_times) / ramp),         # out after it
            _smoothstep(relative_times / min(ramp, max(t_first, dt))),      # zero at the start ...
            _smoothstep((total - relative_times) / min(ramp, max(total - t_last, dt)))])   # ... and goal
        rate = np.gradient(weight, relative_times)
        for side, direction in directions:
            states = base.copy()
            states[:, :2] += amplitude * weight[:, None] * direction
            states[:, 2:] += amplitude * rate[:, None] * direction
            candidates.append((f'detour {side} {amplitude:.2f} m around {other.name}', states))
    return candidates


def replan_process_role(planner_config: GPPlannerConfig, robot_env: RobotEnvironment, own: SharedRole,
                        others: list[SharedRole], now: float, position, *, horizon: float,
                        min_remaining: float = 1.0, avoidance: AvoidanceSettings | None = None) -> Replan:
    """Algorithm 4 lines 3-6: conflicts with the others' roles, then GP inference from here.

    The remaining part of the own role, resampled from ``now`` with the same number of
    states, is the warm start; the start state is the tracked ``position`` with the role's
    velocity at ``now``, the goal the role's destination at rest. The others are moving
    obstacles at the same times; when the warm-started plan still comes too close to one,
    detour initialisations are optimised too and the best plan is kept (module docstring).
    With less than ``min_remaining`` seconds left the role is kept (nothing left worth
    re-optimising).
    """
    avoidance = AvoidanceSettings() if avoidance is None else avoidance
    elapsed = now - own.start_time
    remaining = own.total_time - elapsed
    if remaining < min_remaining:
        return Replan(None, own.start_time, own.total_time, [], 'role nearly over')
    conflicting = [c.name for c in find_conflicts(own, others, now, horizon=horizon,
                                                   clearance=avoidance.clearance)]
    count = len(own.trajectory)
    relative_times = np.linspace(0.0, remaining, count)
    positions, velocities, _ = interpolate(own.trajectory, own.total_time, elapsed + relative_times)
    initial = np.hstack([positions, velocities])
    start = np.concatenate([np.asarray(position, dtype=float), velocities[0]])
    initial[0] = start
    goal = np.concatenate([own.trajectory[-1, :2], [0.0, 0.0]])
    planner = GPPlanner(planner_config, robot_env.sdf)
    extra = moving_obstacle_terms(own.radius, others, now + relative_times, avoidance)

    def solve(states: np.ndarray) -> tuple[GPPlanResult, float]:
        result = planner.plan(states, remaining, start=start, goal=goal, extra_terms=extra)
        if not np.isfinite(result.trajectory).all():
            return result, -math.inf
        gaps = role_gaps(result.trajectory, now, remaining, own.radius, others)
        return result, min(gaps.values(), default=math.inf)

    tried = [('warm start', *solve(initial))]
    if tried[0][2] < 0.5 * avoidance.clearance and others and np.isfinite(tried[0][1].trajectory).all():
        base = tried[0][1].trajectory
        gaps = role_gaps(base, now, remaining, own.radius, others)
        nearest = min(others, key=lambda other: gaps[other.name])
        speed = planner_config.max_speed or DEFAULT_DETOUR_SPEED
        for label, states in detour_initialisations(base, relative_times, own.radius, nearest, now, avoidance,
                                                    speed):
            tried.append((label, *solve(states)))
    usable = [entry for entry in tried if np.isfinite(entry[1].trajectory).all() and np.isfinite(entry[1].cost)]
    if not usable:
        return Replan(None, own.start_time, own.total_time, conflicting, 'GP inference diverged',
                      candidates=len(tried))
    label, best, gap = min(usable, key=lambda e: (not (e[2] >= 0.0 and e[1].collision_free), e[1].cost))
    return Replan(best.trajectory, float(now), float(remaining), conflicting, cost=float(best.cost), min_gap=gap,
                  initialisation=label, candidates=len(tried), term_costs=dict(best.term_costs))

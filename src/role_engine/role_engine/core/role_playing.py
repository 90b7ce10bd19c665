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
of the relative motion -- and keeps the best result. Detours are also tried when the
warm-started plan keeps the gap only by pressing into a wall.

In a passage too narrow to pass side by side no detour is collision-free and wall-free. Then
the rule of :mod:`.yielding` (first into the conflict area keeps its role, ties by name,
computed from the shared roles only) decides per conflicting robot: towards one that keeps
its role, the robot adds *waiting* candidates (drive to a free spot off the other's path,
hold until the other's role has cleared, then go on; the role's total time grows so the
speed limit holds); towards ones that yield to it, it adds a *right of way* candidate, the
warm start optimised without those robots' roles (they are about to wait), whose gap is
measured against the remaining robots only.

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
from typing import Any

import numpy as np

from collab_tools.core.fields import Fields

from .conflict import SharedRole, find_conflicts
from .environment import RobotEnvironment
from .errors import RoleEngineError, check_count, check_real
from .gp_costs import CostTerm, InterpolatedMovingObstacleTerm, MovingObstacleTerm
from .gp_planner import GPPlanner, GPPlannerConfig, GPPlanResult
from .trajectory import interpolate, nearest_time
from .yielding import right_of_way, waiting_plans

#: A robot at most this far from its role [m] re-plans the rest from its role point (see replan_process_role).
REJOIN_DISTANCE = 0.15
#: Speed used to time a detour's ramps when the planner has no speed limit [m/s].
DEFAULT_DETOUR_SPEED = 0.5
#: Instants per interval at which separations between roles are measured (reports, choice).
SEPARATION_SAMPLES = 10
#: A waiting plan drives at this share of the GP speed limit, so its optimised role respects Eq. 22.
YIELD_SPEED_FRACTION = 0.8
#: Support intervals added after a waiting plan reaches its goal, for the GP to slow down to rest.
YIELD_SETTLE_INTERVALS = 2


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
        check_real(self.clearance, 'robot_avoidance.clearance', non_negative=True)
        check_real(self.sigma, 'robot_avoidance.sigma', positive=True)
        check_count(self.interpolation, 'robot_avoidance.interpolation', minimum=0)
        scales = tuple(self.detour_scales)
        for index, scale in enumerate(scales):
            check_real(scale, f'robot_avoidance.detour_scales[{index}]', positive=True)
        object.__setattr__(self, 'detour_scales', tuple(float(s) for s in scales))

    @classmethod
    def from_mapping(cls, data: Any, path: str = 'robot_avoidance') -> 'AvoidanceSettings':
        """From a settings-file mapping; unknown keys and bad values name ``path.field``."""
        fields = Fields(data if data is not None else {}, path,
                        allowed=('clearance', 'sigma', 'interpolation', 'detour_scales'), error=RoleEngineError)
        scales = fields.raw('detour_scales', list(cls.detour_scales))
        if not isinstance(scales, (list, tuple)):
            raise RoleEngineError(f'{path}.detour_scales: must be a list of numbers > 0 (got {scales!r})')
        values = dict(clearance=fields.number('clearance', cls.clearance, ge=0.0),
                      sigma=fields.number('sigma', cls.sigma, gt=0.0),
                      interpolation=fields.integer('interpolation', cls.interpolation, ge=0))
        try:   # the detour scales are checked by __post_init__, whose errors say robot_avoidance
            return cls(**values, detour_scales=tuple(scales))
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
    #: The robots this plan waits for (a yielding plan won), else empty.
    yielding_to: list[str] = field(default_factory=list)
    #: The robots expected to yield to this one (right of way); ``min_gap`` then leaves them out.
    right_of_way_over: list[str] = field(default_factory=list)
    #: (arrival at the waiting spot, release) in absolute time of the winning waiting plan, else None.
    waiting: tuple[float, float] | None = None


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

    The remaining part of the own role from where the robot is along it (the role time whose
    position is nearest the tracked ``position``, searched around the role's clock:
    trajectory.nearest_time), resampled with the same number of states and timed as the role
    planned it, is the warm start; the start state is the tracked ``position`` with the role's
    velocity there, the goal the role's destination at rest. (Resampling from the clock instead
    would, for a robot that lags, start with a chord from the robot straight to the clock's point
    -- across the inside of a bend, into the obstacle the role went round -- and with the clock's
    velocity, which round a bend points elsewhere: the re-planned role then swings across the
    corridor at every re-plan.) The others are moving
    obstacles at the same times; when the warm-started plan still comes too close to one,
    detour initialisations are optimised too, and when none of those is collision-free and
    wall-free either, the narrow-passage rule of :mod:`.yielding` decides: the robot either
    waits (yielding candidates) or keeps its role against the robots that yield to it (right
    of way). The best plan is kept (module docstring). With less than ``min_remaining``
    seconds left the role is kept (nothing left worth re-optimising).
    """
    avoidance = AvoidanceSettings() if avoidance is None else avoidance
    # Where the robot is along its role (the nearest point of the role's path around its clock), not
    # where the clock says: the rest of the role from there is the warm start, timed as planned.
    elapsed = nearest_time(own.trajectory, own.total_time, position, now - own.start_time)
    remaining = own.total_time - elapsed
    if remaining < min_remaining:
        return Replan(None, own.start_time, own.total_time, [], 'role nearly over')
    conflicting = [c.name for c in find_conflicts(own, others, now, horizon=horizon,
                                                   clearance=avoidance.clearance)]
    count = len(own.trajectory)
    relative_times = np.linspace(0.0, remaining, count)
    positions, velocities, _ = interpolate(own.trajectory, own.total_time, elapsed + relative_times)
    initial = np.hstack([positions, velocities])
    # A robot within REJOIN_DISTANCE of its role is the controller's to bring back: the rest of the
    # role starts where the robot is *along* it, so the role stays the smooth, centred path it was
    # instead of bending to every tracking error (the re-plan would then chase the robot and the
    # robot the re-plan: a zig-zag). Farther off, or with another robot in conflict (the role is
    # what the others plan around, so it starts where the robot really is), it starts from the robot.
    here = np.asarray(position, dtype=float)
    rejoin = not conflicting and math.dist(here, positions[0]) <= REJOIN_DISTANCE
    anchor = positions[0] if rejoin else here
    start = np.concatenate([anchor, velocities[0]])
    initial[0] = start
    goal = np.concatenate([own.trajectory[-1, :2], [0.0, 0.0]])
    planner = GPPlanner(planner_config, robot_env.sdf)
    speed = planner_config.max_speed or DEFAULT_DETOUR_SPEED

    def solve(label: str, states: np.ndarray, total: float, respected: list[SharedRole]) -> _Candidate:
        extra = moving_obstacle_terms(own.radius, respected, now + np.linspace(0.0, total, len(states)), avoidance)
        result = planner.plan(states, total, start=start, goal=goal, extra_terms=extra)
        if not np.isfinite(result.trajectory).all():
            return _Candidate(label, result, -math.inf, total)
        gaps = role_gaps(result.trajectory, now, total, own.radius, respected)
        return _Candidate(label, result, min(gaps.values(), default=math.inf), total)

    tried = [solve('warm start', initial, remaining, others)]
    warm = tried[0]
    in_conflict: list[SharedRole] = []
    if others and warm.finite:
        # Conflicting robots: too close to the role as published or to its re-optimised version
        # (the GP may keep the gap by pressing the plan into a wall instead).
        published = role_gaps(initial, now, remaining, own.radius, others)
        gaps = role_gaps(warm.result.trajectory, now, remaining, own.radius, others)
        in_conflict = [other for other in others
                       if min(published[other.name], gaps[other.name]) < 0.5 * avoidance.clearance]
        if warm.gap < 0.5 * avoidance.clearance or (in_conflict and not warm.result.collision_free):
            nearest = min(in_conflict or others, key=lambda other: min(published[other.name], gaps[other.name]))
            for label, states in detour_initialisations(warm.result.trajectory, relative_times, own.radius,
                                                        nearest, now, avoidance, speed):
                tried.append(solve(label, states, remaining, others))
    yielding_to: list[str] = []
    right_of_way_over: list[str] = []
    if in_conflict and not any(c.feasible for c in tried):
        # Narrow passage (core/yielding.py): no detour passes, so one of each conflicting pair waits.
        blocking = in_conflict
        keeps = {other.name: right_of_way(own, other, robot_env, now, avoidance.clearance) for other in blocking}
        give_way = [other for other in blocking if keeps[other.name] is True]
        respected = [other for other in others if other not in give_way]
        yield_to = [other for other in blocking if keeps[other.name] is not True]
        if yield_to:
            yielding_to = [other.name for other in yield_to]
            dt = remaining / (count - 1)
            for plan in waiting_plans(robot_env, own.radius, position, goal[:2], now, yield_to, respected,
                                      clearance=avoidance.clearance, speed=YIELD_SPEED_FRACTION * speed,
                                      spot_clearance=planner_config.epsilon):
                needed = plan.finish - now + YIELD_SETTLE_INTERVALS * dt
                states_count = count if needed <= remaining else int(math.ceil(needed / dt)) + 1
                total = remaining if needed <= remaining else (states_count - 1) * dt
                states = plan.states(now + np.linspace(0.0, total, states_count), start)
                candidate = solve(f"yield to {', '.join(yielding_to)}: {plan.label}", states, total, respected)
                candidate.waiting = (plan.arrive, plan.release)
                tried.append(candidate)
        elif give_way:
            right_of_way_over = [other.name for other in give_way]
            tried.append(solve(f"right of way over {', '.join(right_of_way_over)}", initial, remaining, respected))
    usable = [c for c in tried if c.finite and np.isfinite(c.result.cost)]
    if not usable:
        return Replan(None, own.start_time, own.total_time, conflicting, 'GP inference diverged',
                      candidates=len(tried), yielding_to=yielding_to)
    best = min(usable, key=lambda c: (not c.feasible, c.result.cost))
    won_yield = best.label.startswith('yield')
    return Replan(best.result.trajectory, float(now), float(best.total), conflicting,
                  cost=float(best.result.cost), min_gap=best.gap, initialisation=best.label, candidates=len(tried),
                  term_costs=dict(best.result.term_costs), yielding_to=yielding_to if won_yield else [],
                  right_of_way_over=right_of_way_over if best.label.startswith('right of way') else [],
                  waiting=best.waiting)


@dataclass
class _Candidate:
    """One optimised initialisation: its GP result, its min gap to the robots it respects, its duration."""

    label: str
    result: GPPlanResult
    gap: float
    total: float
    waiting: tuple[float, float] | None = None

    @property
    def finite(self) -> bool:
        return bool(np.isfinite(self.result.trajectory).all())

    @property
    def feasible(self) -> bool:
        """Collision-free and wall-free: the choice's first criterion."""
        return self.finite and self.gap >= 0.0 and bool(self.result.collision_free)

"""What a role node lets a user tune while it runs, as flat named values (the nodes' ROS parameters).

The shared settings file (:class:`~.formation_task.FormationTask`) holds the team-wide defaults;
a node starts from them (:meth:`PlayerTuning.from_task`, :meth:`EngineTuning.from_task`), a
start-up parameter or a later ``set_parameters`` replaces one value (:meth:`with_values`,
validated, errors name the value), and the node reads its tuning object at every use, so a new
value applies from the next control step, re-plan or check. The flat names are the settings
file's paths (``gp.epsilon``, ``robot_avoidance.sigma``, ``problem_detection.stuck_time``).

Role player:

* ``replan_period``, ``conflict_horizon``, ``speed_fraction``, ``gp.*`` (:data:`PLAYER_GP_FIELDS`)
  and ``robot_avoidance.*``: the next re-plan;
* ``arrival_tolerance``, ``controller.*`` (tracking gains) and ``max_linear_velocity`` /
  ``max_angular_velocity``: the next command. The velocity caps (at most the robot type's limits)
  clamp the commands, and the re-plans' GP speed limit is ``speed_fraction x max_linear_velocity``
  so a re-planned role can be driven under the cap.

The GP prior's model constants (``qc``, the start/goal/velocity sigmas, the collision check
density) stay team-wide in the settings file: the engine evaluates roles with the same model.

``robot_avoidance.detour_scales`` is a list of numbers >= 0 where 0 entries are skipped: a ROS
parameter cannot be an empty typed list, so ``[0.0]`` says "no detour" (an empty list in the file).
"""
from __future__ import annotations

from dataclasses import dataclass, fields, replace
from typing import Any, Mapping

from collab_tools.core.settings import echo

from .controller import TrackingGains, TrajectoryFollower
from .environment import RobotType
from .errors import RoleEngineError, check_count, check_real
from .gp_planner import FORMULATIONS, GPPlannerConfig
from .problems import ProblemSettings
from .role_playing import AvoidanceSettings

#: GP settings a role player may tune for its own re-plans (the rest stay team-wide).
PLAYER_GP_FIELDS = ('epsilon', 'sigma_obs', 'lambda_initial', 'max_iterations', 'relative_error_tol',
                    'obstacle_interpolation', 'formulation')
#: GP fields that are not floats (an integer or text parameter).
GP_TEXT_OR_COUNT = ('max_iterations', 'obstacle_interpolation', 'formulation')
AVOIDANCE_FIELDS = ('clearance', 'sigma', 'interpolation', 'detour_scales')
GAIN_FIELDS = tuple(f.name for f in fields(TrackingGains))
PROBLEM_FIELDS = ('stuck_distance', 'stuck_time', 'off_role_distance', 'off_role_grace')


def _detour_scales(value: Any, path: str) -> tuple[float, ...]:
    if isinstance(value, (str, bytes)) or not hasattr(value, '__iter__'):
        raise RoleEngineError(f'{path}: must be a list of numbers >= 0 (got {echo(value)})')
    scales = [check_real(v, f'{path}[{i}]', non_negative=True) for i, v in enumerate(value)]
    return tuple(s for s in scales if s > 0.0)


def _split(name: str, sections: tuple[str, ...]) -> tuple[str, str]:
    section, dot, field = name.partition('.')
    return (section, field) if dot and section in sections else ('', name)


@dataclass(frozen=True)
class PlayerTuning:
    """A role player's tuning (module docstring); ``robot_type`` carries the platform limits."""

    robot_type: RobotType
    replan_period: float
    arrival_tolerance: float
    conflict_horizon: float
    speed_fraction: float
    max_linear_velocity: float
    max_angular_velocity: float
    gains: TrackingGains
    avoidance: AvoidanceSettings
    gp: GPPlannerConfig                  # max_speed is set per re-plan (gp_config)

    def __post_init__(self) -> None:
        check_real(self.replan_period, 'replan_period', positive=True)
        check_real(self.arrival_tolerance, 'arrival_tolerance', positive=True)
        check_real(self.conflict_horizon, 'conflict_horizon', non_negative=True)
        if not 0.0 < check_real(self.speed_fraction, 'speed_fraction') <= 1.0:
            raise RoleEngineError(f'speed_fraction: must be in (0, 1] (got {self.speed_fraction})')
        for name, limit in (('max_linear_velocity', self.robot_type.max_linear_velocity),
                            ('max_angular_velocity', self.robot_type.max_angular_velocity)):
            value = check_real(getattr(self, name), name, positive=True)
            if limit is not None and value > limit:
                raise RoleEngineError(f'{name}: must be <= the {self.robot_type.name} limit {limit:g} (got {value:g})')

    @classmethod
    def from_task(cls, task, robot_type: RobotType) -> 'PlayerTuning':
        """The settings file's values; the velocity caps start at the robot type's limits."""
        if robot_type.max_linear_velocity is None or robot_type.max_angular_velocity is None:
            raise RoleEngineError(f'robot_type {robot_type.name!r}: a role player needs its velocity limits')
        return cls(robot_type=robot_type, replan_period=float(task.replan_period),
                   arrival_tolerance=float(task.arrival_tolerance), conflict_horizon=float(task.conflict_horizon),
                   speed_fraction=float(task.speed_fraction),
                   max_linear_velocity=float(robot_type.max_linear_velocity),
                   max_angular_velocity=float(robot_type.max_angular_velocity), gains=task.controller,
                   avoidance=task.robot_avoidance, gp=task.gp_config(replace(robot_type, max_linear_velocity=None)))

    def values(self) -> dict[str, Any]:
        """Flat name -> value (ints stay ints, floats floats, detour_scales a list)."""
        out: dict[str, Any] = {name: getattr(self, name) for name in (
            'replan_period', 'arrival_tolerance', 'conflict_horizon', 'speed_fraction', 'max_linear_velocity',
            'max_angular_velocity')}
        out.update({f'controller.{name}': float(getattr(self.gains, name)) for name in GAIN_FIELDS})
        out.update({'robot_avoidance.clearance': float(self.avoidance.clearance),
                    'robot_avoidance.sigma': float(self.avoidance.sigma),
                    'robot_avoidance.interpolation': int(self.avoidance.interpolation),
                    'robot_avoidance.detour_scales': list(self.avoidance.detour_scales) or [0.0]})
        for name in PLAYER_GP_FIELDS:
            value = getattr(self.gp, name)
            out[f'gp.{name}'] = value if name in GP_TEXT_OR_COUNT else float(value)
        return out

    def with_values(self, changes: Mapping[str, Any]) -> 'PlayerTuning':
        """A copy with ``changes`` (flat names) applied; RoleEngineError naming an unknown or bad value."""
        top, gains, avoidance, gp = {}, {}, {}, {}
        for name, value in changes.items():
            section, field = _split(name, ('controller', 'robot_avoidance', 'gp'))
            if section == 'controller' and field in GAIN_FIELDS:
                gains[field] = check_real(value, name, positive=True)
            elif section == 'robot_avoidance' and field in AVOIDANCE_FIELDS:
                avoidance[field] = _detour_scales(value, name) if field == 'detour_scales' else value
            elif section == 'gp' and field in PLAYER_GP_FIELDS:
                if field == 'formulation' and value not in FORMULATIONS:
                    raise RoleEngineError(f"{name}: must be one of {', '.join(FORMULATIONS)} (got {echo(value)})")
                gp[field] = value
            elif not section and name in self.values() and '.' not in name:
                top[name] = value
            else:
                raise RoleEngineError(f'{name}: not a tuning value of a role player')
        try:
            gains_value = replace(self.gains, **gains)
        except RoleEngineError as error:
            raise RoleEngineError(str(error).replace('gains.', 'controller.', 1)) from None
        avoidance_value = replace(self.avoidance, **avoidance)   # its errors name robot_avoidance.*
        try:
            gp_value = replace(self.gp, **gp)
        except ValueError as error:
            raise RoleEngineError(str(error).replace('GPPlannerConfig.', 'gp.', 1)) from None
        return replace(self, gains=gains_value, avoidance=avoidance_value, gp=gp_value, **top)

    # --- what the node builds from it -------------------------------------------------------
    def capped_type(self) -> RobotType:
        """The robot type with the velocity caps as its limits (the controller clamps to them)."""
        return replace(self.robot_type, max_linear_velocity=self.max_linear_velocity,
                       max_angular_velocity=self.max_angular_velocity)

    def gp_config(self) -> GPPlannerConfig:
        """GP settings of a re-plan: speed limit (Eq. 22) = speed_fraction x max_linear_velocity."""
        return replace(self.gp, max_speed=self.speed_fraction * self.max_linear_velocity)

    def follower(self, trajectory, total_time: float) -> TrajectoryFollower:
        """The controller of a role; it stops within half the arrival tolerance of a point at rest."""
        return TrajectoryFollower(trajectory, total_time, self.capped_type(), gains=self.gains,
                                  position_tolerance=0.5 * self.arrival_tolerance)


@dataclass(frozen=True)
class EngineTuning:
    """The role engine's tuning: the next negotiation (start_delay, min_robots, qualification_lambda)
    and the next problem check (silence_timeout, problem_detection.*)."""

    start_delay: float
    qualification_lambda: float
    min_robots: int
    problems: ProblemSettings

    def __post_init__(self) -> None:
        check_real(self.start_delay, 'start_delay', non_negative=True)
        check_real(self.qualification_lambda, 'qualification_lambda', non_negative=True)
        check_count(self.min_robots, 'min_robots', minimum=1)

    @classmethod
    def from_task(cls, task) -> 'EngineTuning':
        problems = task.problem_detection or ProblemSettings(silence_timeout=task.silence_timeout)
        return cls(float(task.start_delay), float(task.qualification_lambda), int(task.min_robots), problems)

    def values(self) -> dict[str, Any]:
        out: dict[str, Any] = {'start_delay': self.start_delay, 'qualification_lambda': self.qualification_lambda,
                               'min_robots': self.min_robots,
                               'silence_timeout': float(self.problems.silence_timeout)}
        out.update({f'problem_detection.{name}': float(getattr(self.problems, name)) for name in PROBLEM_FIELDS})
        return out

    def with_values(self, changes: Mapping[str, Any]) -> 'EngineTuning':
        top, problems = {}, {}
        for name, value in changes.items():
            section, field = _split(name, ('problem_detection',))
            if section and field in PROBLEM_FIELDS:
                problems[field] = value
            elif name == 'silence_timeout':
                problems[name] = value
            elif name in ('start_delay', 'qualification_lambda', 'min_robots'):
                top[name] = value
            else:
                raise RoleEngineError(f'{name}: not a tuning value of the role engine')
        if 'silence_timeout' in problems:
            check_real(problems['silence_timeout'], 'silence_timeout', positive=True)
        return replace(self, problems=replace(self.problems, **problems), **top)

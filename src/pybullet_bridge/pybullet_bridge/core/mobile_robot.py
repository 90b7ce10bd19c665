"""Differential-drive mobile robots (the ``mobile_robots`` scenario section).

A robot has a type (body size, mass, drive limits, command timeout: :mod:`.robot_types`),
any of whose fields it may override, a start pose, a colour the camera tells it apart by,
and the sensors it carries (:mod:`.sensor_config`). Definition and parsing only; :mod:`.mobile_robot_body` drives the robot in pybullet.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from collab_tools.core.fields import Fields, fail, join_path, require_list

from .diff_drive import DiffDriveLimits
from .entity import EntityDefinition
from .errors import ScenarioError
from .robot_types import ROBOT_TYPE_FIELDS
from .sections import SectionContext
from .sensor_config import SensorSet, parse_robot_sensors

#: Robots' colours must be at least this far apart (Euclidean RGB) to be told apart on camera.
MIN_COLOR_DISTANCE = 0.1


@dataclass(frozen=True)
class RobotParams:
    type_name: str
    radius: float
    height: float
    mass: float
    limits: DiffDriveLimits
    command_timeout: float
    color: tuple[float, float, float]

    @classmethod
    def from_type(cls, type_name: str, fields: dict[str, float],
                  color: tuple[float, float, float]) -> RobotParams:
        """Build from a robot type dict with every key of ROBOT_TYPE_FIELDS."""
        return cls(
            type_name=type_name, radius=fields['radius'], height=fields['height'], mass=fields['mass'],
            limits=DiffDriveLimits(
                max_linear_velocity=fields['max_linear_velocity'],
                max_angular_velocity=fields['max_angular_velocity'],
                max_linear_acceleration=fields['max_linear_acceleration'],
                max_angular_acceleration=fields['max_angular_acceleration']),
            command_timeout=fields['command_timeout'], color=tuple(color))  # type: ignore[arg-type]


def yaw_quaternion(yaw: float) -> tuple[float, float, float, float]:
    """xyzw quaternion of a rotation by ``yaw`` about z."""
    return (0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0))


def yaw_of(quaternion_xyzw: tuple[float, ...]) -> float:
    x, y, z, w = quaternion_xyzw
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


@dataclass(eq=False)
class MobileRobot(EntityDefinition):
    """A differential-drive robot as the scenario defines it: type parameters, start pose, sensors."""

    kind = 'mobile_robot'

    name: str
    params: RobotParams
    initial_pose: tuple[float, float, float]
    config_path: str = ''
    #: Simulated sensors the robot carries (core/sensor_config.py); None: none.
    sensors: SensorSet | None = None

    def __post_init__(self):
        self.initial_pose = tuple(float(v) for v in self.initial_pose)


def parse_mobile_robots(value: Any, context: SectionContext) -> list[MobileRobot]:
    """Parse the ``mobile_robots`` section: a list of robot entries."""
    if value is None:
        return []
    robots: list[MobileRobot] = []
    for index, item in enumerate(require_list(value, context.path, error=ScenarioError)):
        path = join_path(context.path, index)
        fields = Fields(item, path, allowed=('name', 'type', 'pose', 'color', *ROBOT_TYPE_FIELDS, 'sensors'), error=ScenarioError)
        name = fields.name('name')
        type_name = fields.string('type')
        if type_name not in context.robot_types:
            raise fail(fields.path_of('type'), f"unknown robot type '{type_name}' "
                       f"(known: {', '.join(context.robot_types)})", error=ScenarioError)
        type_fields = {key: fields.number(key, context.robot_types[type_name][key], gt=0.0)
                       for key in ROBOT_TYPE_FIELDS}
        pose = fields.vector('pose', 3)
        if not context.world.contains(pose[0], pose[1], margin=type_fields['radius']):
            raise fail(fields.path_of('pose'), f'robot footprint (x {pose[0]}, y {pose[1]}, radius '
                       f"{type_fields['radius']}) must lie inside world.bounds {list(context.world.bounds)}", error=ScenarioError)
        color = fields.color('color')
        for other in robots:
            distance = math.dist(color, other.params.color)
            if distance < MIN_COLOR_DISTANCE:
                raise fail(fields.path_of('color'), f'{list(color)} is too close to the colour of '
                           f'{other.config_path} {list(other.params.color)} (distance {distance:.3f} < '
                           f'{MIN_COLOR_DISTANCE}); robots must be distinguishable on camera', error=ScenarioError)
        params = RobotParams.from_type(type_name, type_fields, color)
        sensors = parse_robot_sensors(fields.raw('sensors', None), fields.path_of('sensors'),
                                      context.seed, index)
        robots.append(MobileRobot(name, params, pose, config_path=path,  # type: ignore[arg-type]
                                  sensors=sensors))
    return robots


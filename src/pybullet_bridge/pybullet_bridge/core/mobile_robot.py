"""Differential-drive mobile robots (the ``mobile_robots`` scenario section).

A robot is a cylinder driven kinematically: every physics step its base velocity
is set from the (rate- and timeout-limited) command, and pybullet's contact
solver stops it at obstacles. It is kept planar and upright.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import pybullet as p

from .diff_drive import DiffDriveLimits, limit_velocity
from .fields import Fields, fail, join_path, require_list
from .scenario import ROBOT_TYPE_FIELDS, SectionContext, register_section
from .scene import SceneEntity
from .sensor_config import SensorSet, parse_robot_sensors

#: Robots' colours must be at least this far apart (Euclidean RGB) to be told apart on camera.
MIN_COLOR_DISTANCE = 0.1
#: Colour of the heading marker on top of every robot.
MARKER_RGBA = (0.05, 0.05, 0.05, 1.0)
# Tolerances beyond which after_step puts a robot back on the ground plane, level.
_TILT_TOLERANCE = 1e-3   # rad
_HEIGHT_TOLERANCE = 2e-3  # m


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


class MobileRobot(SceneEntity):
    kind = 'mobile_robot'

    def __init__(self, name: str, params: RobotParams, initial_pose: tuple[float, float, float],
                 config_path: str = '', sensors: SensorSet | None = None):
        self.name = name
        self.params = params
        self.initial_pose = tuple(float(v) for v in initial_pose)
        self.config_path = config_path
        #: Simulated sensors the robot carries (core/sensor_config.py); None: none.
        self.sensors = sensors
        self._reset_motion_state()

    def _reset_motion_state(self) -> None:
        self._command = (0.0, 0.0)
        self._command_time: float | None = None
        self._velocity = (0.0, 0.0)

    # -- commands -------------------------------------------------------------

    def set_command(self, linear: float, angular: float, sim_time: float) -> None:
        """Ask for (linear m/s, angular rad/s) from ``sim_time`` on; values beyond limits are clamped."""
        if not (math.isfinite(linear) and math.isfinite(angular)):
            raise ValueError(f"robot '{self.name}': non-finite velocity command "
                             f'(linear {linear}, angular {angular}); keeping the previous command')
        limits = self.params.limits
        self._command = (max(-limits.max_linear_velocity, min(limits.max_linear_velocity, float(linear))),
                         max(-limits.max_angular_velocity, min(limits.max_angular_velocity, float(angular))))
        self._command_time = float(sim_time)

    def commanded_velocity(self) -> tuple[float, float]:
        """Last accepted command, after clamping to the velocity limits."""
        return self._command

    def command_is_fresh(self, sim_time: float) -> bool:
        """True while the last command is younger than the command timeout."""
        return (self._command_time is not None
                and sim_time - self._command_time <= self.params.command_timeout)

    def velocity(self) -> tuple[float, float]:
        """(linear, angular) velocity currently applied, after acceleration limits."""
        return self._velocity

    # -- physics ----------------------------------------------------------------

    def spawn(self, client: int) -> list[int]:
        self._reset_motion_state()
        radius, height = self.params.radius, self.params.height
        collision = p.createCollisionShape(p.GEOM_CYLINDER, radius=radius, height=height,
                                           physicsClientId=client)
        visual = p.createVisualShape(p.GEOM_CYLINDER, radius=radius, length=height,
                                     rgbaColor=[*self.params.color, 1.0], physicsClientId=client)
        # The heading marker is a massless-looking fixed link (not a separate body) so
        # it carries the robot's segmentation label; it stays inside the footprint.
        marker = p.createVisualShape(p.GEOM_BOX, halfExtents=[0.25 * radius, 0.1 * radius, 0.004],
                                     rgbaColor=list(MARKER_RGBA), physicsClientId=client)
        x, y, yaw = self.initial_pose
        body = p.createMultiBody(
            baseMass=self.params.mass, baseCollisionShapeIndex=collision, baseVisualShapeIndex=visual,
            basePosition=[x, y, height / 2.0], baseOrientation=yaw_quaternion(yaw),
            linkMasses=[0.001], linkCollisionShapeIndices=[-1], linkVisualShapeIndices=[marker],
            linkPositions=[[0.6 * radius, 0.0, height / 2.0 + 0.004]], linkOrientations=[[0, 0, 0, 1]],
            linkInertialFramePositions=[[0, 0, 0]], linkInertialFrameOrientations=[[0, 0, 0, 1]],
            linkParentIndices=[0], linkJointTypes=[p.JOINT_FIXED], linkJointAxis=[[0, 0, 1]],
            physicsClientId=client)
        # Motion is imposed through the base velocity: ground friction and damping
        # would only make the robot fall short of its command.
        for link in (-1, 0):
            p.changeDynamics(body, link, lateralFriction=0.0, spinningFriction=0.0, rollingFriction=0.0,
                             linearDamping=0.0, angularDamping=0.0, physicsClientId=client)
        return [body]

    def pose2d(self, client: int) -> tuple[float, float, float]:
        """(x, y, yaw) of the robot in the world."""
        position, orientation = p.getBasePositionAndOrientation(self.body_ids[0], physicsClientId=client)
        return position[0], position[1], yaw_of(orientation)

    def before_step(self, client: int, dt: float, sim_time: float) -> None:
        target = self._command if self.command_is_fresh(sim_time) else (0.0, 0.0)
        self._velocity = limit_velocity(target, self._velocity, self.params.limits, dt)
        linear, angular = self._velocity
        _, _, yaw = self.pose2d(client)
        p.resetBaseVelocity(self.body_ids[0], [linear * math.cos(yaw), linear * math.sin(yaw), 0.0],
                            [0.0, 0.0, angular], physicsClientId=client)

    def after_step(self, client: int, dt: float, sim_time: float) -> None:
        # Contacts (another robot, an obstacle corner) can tip or lift the cylinder;
        # a planar robot must not, so undo any such drift while keeping x, y, yaw.
        body = self.body_ids[0]
        position, orientation = p.getBasePositionAndOrientation(body, physicsClientId=client)
        roll, pitch, yaw = p.getEulerFromQuaternion(orientation)
        resting_z = self.params.height / 2.0
        if (abs(roll) > _TILT_TOLERANCE or abs(pitch) > _TILT_TOLERANCE
                or abs(position[2] - resting_z) > _HEIGHT_TOLERANCE):
            linear, angular = p.getBaseVelocity(body, physicsClientId=client)
            p.resetBasePositionAndOrientation(body, [position[0], position[1], resting_z],
                                              yaw_quaternion(yaw), physicsClientId=client)
            p.resetBaseVelocity(body, [linear[0], linear[1], 0.0], [0.0, 0.0, angular[2]],
                                physicsClientId=client)


def parse_mobile_robots(value: Any, context: SectionContext) -> list[MobileRobot]:
    """Parse the ``mobile_robots`` section: a list of robot entries."""
    if value is None:
        return []
    robots: list[MobileRobot] = []
    for index, item in enumerate(require_list(value, context.path)):
        path = join_path(context.path, index)
        fields = Fields(item, path, allowed=('name', 'type', 'pose', 'color', *ROBOT_TYPE_FIELDS, 'sensors'))
        name = fields.name('name')
        type_name = fields.string('type')
        if type_name not in context.robot_types:
            raise fail(fields.path_of('type'), f"unknown robot type '{type_name}' "
                       f"(known: {', '.join(context.robot_types)})")
        type_fields = {key: fields.number(key, context.robot_types[type_name][key], gt=0.0)
                       for key in ROBOT_TYPE_FIELDS}
        pose = fields.vector('pose', 3)
        if not context.world.contains(pose[0], pose[1], margin=type_fields['radius']):
            raise fail(fields.path_of('pose'), f'robot footprint (x {pose[0]}, y {pose[1]}, radius '
                       f"{type_fields['radius']}) must lie inside world.bounds {list(context.world.bounds)}")
        color = fields.color('color')
        for other in robots:
            distance = math.dist(color, other.params.color)
            if distance < MIN_COLOR_DISTANCE:
                raise fail(fields.path_of('color'), f'{list(color)} is too close to the colour of '
                           f'{other.config_path} {list(other.params.color)} (distance {distance:.3f} < '
                           f'{MIN_COLOR_DISTANCE}); robots must be distinguishable on camera')
        params = RobotParams.from_type(type_name, type_fields, color)
        sensors = parse_robot_sensors(fields.raw('sensors', None), fields.path_of('sensors'),
                                      context.seed, index)
        robots.append(MobileRobot(name, params, pose, config_path=path,  # type: ignore[arg-type]
                                  sensors=sensors))
    return robots


register_section('mobile_robots', parse_mobile_robots)

"""A differential-drive robot in pybullet (its definition: :mod:`.mobile_robot`).

A robot is a cylinder driven kinematically: every physics step its base velocity
is set from the (rate- and timeout-limited) command, and pybullet's contact
solver stops it at obstacles. It is kept planar and upright.
"""
from __future__ import annotations

import math

import pybullet as p

from .diff_drive import limit_velocity
from .entity import SceneEntity
from .mobile_robot import MobileRobot, yaw_of, yaw_quaternion

#: Colour of the heading marker on top of every robot.
MARKER_RGBA = (0.05, 0.05, 0.05, 1.0)
# Tolerances beyond which after_step puts a robot back on the ground plane, level.
_TILT_TOLERANCE = 1e-3   # rad
_HEIGHT_TOLERANCE = 2e-3  # m


class SimulatedMobileRobot(MobileRobot, SceneEntity):
    """The robot's body and its drive: commands in, base velocity out, every physics step."""

    def __post_init__(self):
        super().__post_init__()
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

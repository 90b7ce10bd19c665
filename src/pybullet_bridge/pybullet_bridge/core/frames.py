"""The TF frames of a scene: what the bridge publishes on /tf_static and /tf.

Frame names (REP 103/105 conventions; the scenario's ``world.frame_id`` is the root):

* ``<camera>`` (``camera.frame_id``, e.g. ``top_camera``): the camera body, x along the
  optical axis (straight down), z towards image up (world +y);
  ``<camera>_optical_frame``: x right, y down, z along the optical axis, the frame of the
  image, labels and camera info (its pose is what ``<camera>/pose`` publishes);
* ``<robot>/base_link``: a mobile robot's body centre, x along its heading -- the pose
  ground truth gives its main body (dynamic, on /tf at the ground-truth rate);
* ``<robot>/<sensor>_link`` for the fiducial sensor, laser and bumper: fixed to base_link
  (the sensors sit at the robot's centre facing its heading); GPS poses are in the world frame;
* ``<arm>/base_link``: an arm's base on top of its pedestal, x along its yaw;
* ``<table>``: the centre of a table's top surface.

Everything but the mobile robots is fixed, so it goes on /tf_static once per scene load.
"""
from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

from collab_tools.core.tf_tree import Pose

from .arm.definition import Arm
from .entity import BodyStateData
from .mobile_robot import MobileRobot, yaw_quaternion
from .sensor_config import BUMPER, FIDUCIAL, LASER
from .tabletop import Table

#: Sensors with a frame of their own (GPS reports world poses).
SENSOR_LINKS = {FIDUCIAL: 'fiducial_link', LASER: 'laser_link', BUMPER: 'bumper_link'}
OPTICAL_SUFFIX = '_optical_frame'
#: Optical frame in the camera body frame (z forward = body x, x right = body -y, y down = body -z).
BODY_TO_OPTICAL = Pose(rotation=(-0.5, 0.5, -0.5, 0.5))


@dataclass(frozen=True)
class FrameTransform:
    """The pose of frame ``child`` in frame ``parent``."""

    parent: str
    child: str
    pose: Pose


def base_frame(entity_name: str) -> str:
    return f'{entity_name}/base_link'


def sensor_frame(robot: str, sensor: str) -> str:
    """Frame of a robot's sensor readings (KeyError for a sensor without one: gps)."""
    return f'{robot}/{SENSOR_LINKS[sensor]}'


def optical_frame(camera_frame: str) -> str:
    return camera_frame + OPTICAL_SUFFIX


def camera_transforms(world_frame: str, camera_frame: str,
                      optical_position: tuple[float, float, float],
                      optical_xyzw: tuple[float, float, float, float]) -> list[FrameTransform]:
    """world -> camera body -> optical frame, from the optical frame's pose in the world."""
    optical = Pose(tuple(optical_position), tuple(optical_xyzw))
    body = optical.compose(BODY_TO_OPTICAL.inverse())
    return [FrameTransform(world_frame, camera_frame, body),
            FrameTransform(camera_frame, optical_frame(camera_frame), BODY_TO_OPTICAL)]


def static_transforms(world_frame: str, entities: Iterable, camera_frame: str,
                      optical_position: tuple[float, float, float],
                      optical_xyzw: tuple[float, float, float, float]) -> list[FrameTransform]:
    """Every fixed frame of the scene (see the module docstring)."""
    transforms = camera_transforms(world_frame, camera_frame, optical_position, optical_xyzw)
    for entity in entities:
        if isinstance(entity, MobileRobot) and entity.sensors is not None:
            transforms += [FrameTransform(base_frame(entity.name), sensor_frame(entity.name, sensor), Pose())
                           for sensor in entity.sensors.names if sensor in SENSOR_LINKS]
        elif isinstance(entity, Arm):
            x, y, yaw = entity.base
            transforms.append(FrameTransform(world_frame, base_frame(entity.name),
                                             Pose((x, y, entity.base_height), yaw_quaternion(yaw))))
        elif isinstance(entity, Table):
            transforms.append(FrameTransform(world_frame, entity.name,
                                             Pose((entity.center[0], entity.center[1], entity.height))))
    return transforms


def robot_transforms(world_frame: str, bodies: Iterable[BodyStateData]) -> list[FrameTransform]:
    """world -> <robot>/base_link of every mobile robot, from its ground-truth body state."""
    return [FrameTransform(world_frame, base_frame(body.name),
                           Pose(tuple(body.position), tuple(body.orientation_xyzw)))
            for body in bodies if body.kind == MobileRobot.kind]

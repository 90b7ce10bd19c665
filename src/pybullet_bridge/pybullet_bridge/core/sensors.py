"""Simulated per-robot sensors: fiducial, laser, GPS, bumper (configured in :mod:`.sensor_config`).

All sensors sit at the robot's centre and look along its heading. Geometry is planar:
ranges and bearings are measured in the ground plane between body centres.

* **Fiducial** (the paper's relative-position sensor, Sec. V): an entity of one of the
  configured kinds is detected when it is within ``range`` (centre to centre), its
  bearing is within ``fov_deg / 2`` of the heading (edges included) -- the shared rule
  :func:`collab_tools.core.visibility.in_field_of_view`, the one the coalition core's
  geometric sensing uses, so both agree at the edges -- and the line of sight is clear: a pybullet ray from the robot's rim (at half its height) to the
  entity's centre first hits the entity itself, or nothing. Any other body in between
  (a wall, a box, another robot, as in the paper's column formation) hides it. The ray
  starts just outside the robot's own cylinder because a ray test reports only its first
  hit. Noise is added to the reported range and bearing only, never to the decision.
* **Laser**: ``beams`` rays over ``fov_deg`` at half the robot's height (REP 117: no
  return within ``range`` is ``inf``); ranges are from the robot's centre, so the
  minimum is the robot's radius.
* **GPS**: the robot's global x, y, yaw plus Gaussian noise.
* **Bumper**: the entities whose bodies touch the robot (the ground excluded), each
  with the bearing of its contact in the robot's frame, within ``fov_deg``.

:class:`RobotSensors` holds a robot's runtime state: which sensors are active, when each
is due next (``rate`` in simulated time), and one seeded noise generator per sensor.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Union

import numpy as np
import pybullet as p
from collab_tools.core.visibility import in_field_of_view

from .entity import BACKGROUND_LABEL, SceneEntity
from .mobile_robot_body import SimulatedMobileRobot
from .sensor_config import (BUMPER, FIDUCIAL, GPS, LASER, SENSOR_NAMES, BumperConfig, FiducialConfig,
                            GpsConfig, LaserConfig)

if TYPE_CHECKING:
    from .scene import Scene

#: Rays start this far outside the sensing robot's cylinder, so they never hit it.
RAY_START_CLEARANCE = 1e-3  # m
#: A contact point counts as touching when its bodies are at most this far apart.
BUMPER_CONTACT_DISTANCE = 5e-3  # m
# Rates are in simulated time and ticks land on float sums.
_TIME_EPSILON = 1e-9


def wrap_angle(angle: float) -> float:
    """Angle in [-pi, pi)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


@dataclass(frozen=True)
class FiducialDetectionData:
    name: str
    kind: str
    range: float     # m
    bearing: float   # rad, counter-clockwise from the heading
    x: float         # m, robot frame (x forward, y left)
    y: float
    yaw: float       # rad, the entity's heading relative to the robot's (a marker's measured orientation)


@dataclass(frozen=True)
class FiducialReading:
    field_of_view: float   # rad
    max_range: float       # m
    detections: tuple[FiducialDetectionData, ...]


@dataclass(frozen=True)
class LaserReading:
    angle_min: float
    angle_max: float
    angle_increment: float
    range_min: float
    range_max: float
    ranges: np.ndarray     # (beams,) m, inf where nothing was hit


@dataclass(frozen=True)
class GpsReading:
    x: float
    y: float
    yaw: float
    position_std: float
    yaw_std: float


@dataclass(frozen=True)
class BumperContactData:
    name: str
    kind: str
    bearing: float


@dataclass(frozen=True)
class BumperReading:
    contacts: tuple[BumperContactData, ...]

    @property
    def pressed(self) -> bool:
        return bool(self.contacts)


SensorReading = Union[FiducialReading, LaserReading, GpsReading, BumperReading]


def laser_angles(fov_deg: float, beams: int) -> tuple[float, float]:
    """(angle_min, angle_increment) of a laser; a full circle does not repeat its first beam."""
    fov = math.radians(fov_deg)
    if beams == 1:
        return 0.0, 0.0
    if fov_deg >= 360.0:
        return -math.pi, fov / beams
    return -fov / 2.0, fov / (beams - 1)


class RobotSensors:
    """The sensors of one robot in one scene; ``due`` returns what to publish now."""

    def __init__(self, scene: Scene, robot: SimulatedMobileRobot):
        if robot.sensors is None:
            raise ValueError(f"robot '{robot.name}' has no sensors configured")
        self.scene = scene
        self.robot = robot
        self.config = robot.sensors
        self.active = {name: self.config[name].active for name in self.config.names}
        self._next_time = {name: 0.0 for name in self.config.names}
        # One generator per sensor, so switching one sensor never changes another's noise.
        seeds = np.random.SeedSequence(self.config.seed).spawn(len(SENSOR_NAMES))
        self._rng = {name: np.random.default_rng(seeds[SENSOR_NAMES.index(name)])
                     for name in self.config.names}

    @property
    def names(self) -> tuple[str, ...]:
        return self.config.names

    def set_active(self, name: str, active: bool, sim_time: float) -> None:
        """Switch sensor ``name`` on or off; an activated sensor is due at once."""
        if name not in self.config:
            configured = ', '.join(self.names)
            raise KeyError(f"robot '{self.robot.name}' has no sensor '{name}' (it has: {configured})")
        if active and not self.active[name]:
            self._next_time[name] = sim_time
        self.active[name] = bool(active)

    def due(self, sim_time: float) -> list[tuple[str, SensorReading]]:
        """Readings of the active sensors whose period has elapsed, in :data:`SENSOR_NAMES` order."""
        readings = []
        for name in self.names:
            if not self.active[name] or sim_time + _TIME_EPSILON < self._next_time[name]:
                continue
            self._next_time[name] = sim_time + 1.0 / self.config[name].rate
            readings.append((name, self.read(name)))
        return readings

    def read(self, name: str) -> SensorReading:
        """Sense now, whether or not the sensor is active (the scheduling lives in ``due``)."""
        config = self.config[name]
        if name == FIDUCIAL:
            return sense_fiducial(self.scene, self.robot, config, self._rng[name])  # type: ignore[arg-type]
        if name == LASER:
            return sense_laser(self.scene, self.robot, config, self._rng[name])  # type: ignore[arg-type]
        if name == GPS:
            return sense_gps(self.scene, self.robot, config, self._rng[name])  # type: ignore[arg-type]
        if name == BUMPER:
            return sense_bumper(self.scene, self.robot, config)  # type: ignore[arg-type]
        raise KeyError(f"no sensing model for sensor '{name}'")


def _sensor_height(robot: SimulatedMobileRobot) -> float:
    return robot.params.height / 2.0


def _entity_of_body(scene: Scene) -> dict[int, SceneEntity]:
    return {body: entity for entity in scene.entities for body in entity.body_ids}


def sense_fiducial(scene: Scene, robot: SimulatedMobileRobot, config: FiducialConfig,
                   rng: np.random.Generator | None = None) -> FiducialReading:
    client = scene.client
    sx, sy, syaw = robot.pose2d(client)
    sz = _sensor_height(robot)
    half_fov = math.radians(config.fov_deg) / 2.0
    start_offset = robot.params.radius + RAY_START_CLEARANCE
    candidates = []  # (entity, distance, bearing, target centre, relative yaw)
    for entity in scene.entities:
        if entity is robot or entity.kind not in config.kinds:
            continue
        centre, orientation = p.getBasePositionAndOrientation(entity.main_body, physicsClientId=client)
        dx, dy = centre[0] - sx, centre[1] - sy
        if not in_field_of_view(dx, dy, syaw, config.fov_deg, config.range):
            continue
        distance = math.hypot(dx, dy)
        bearing = wrap_angle(math.atan2(dy, dx) - syaw)
        relative_yaw = wrap_angle(p.getEulerFromQuaternion(orientation)[2] - syaw)
        candidates.append((entity, distance, bearing, centre, relative_yaw))
    # Line of sight: one ray per candidate, from just outside the robot to the target's centre.
    rays_from, rays_to, ray_owner = [], [], []
    for index, (_, distance, bearing, centre, _) in enumerate(candidates):
        if distance <= start_offset:
            continue  # touching the robot: nothing can be in between
        heading = syaw + bearing
        rays_from.append([sx + start_offset * math.cos(heading), sy + start_offset * math.sin(heading), sz])
        rays_to.append(list(centre))
        ray_owner.append(index)
    blocked = set()
    if rays_from:
        for index, hit in zip(ray_owner, p.rayTestBatch(rays_from, rays_to, physicsClientId=client)):
            hit_body = hit[0]
            entity = candidates[index][0]
            if hit_body >= 0 and hit_body not in entity.body_ids and hit_body not in robot.body_ids:
                blocked.add(index)
    detections = []
    for index, (entity, distance, bearing, _, relative_yaw) in enumerate(candidates):
        if index in blocked:
            continue
        if rng is not None and config.range_noise_std > 0.0:
            distance = max(0.0, distance + rng.normal(0.0, config.range_noise_std))
        if rng is not None and config.bearing_noise_std > 0.0:
            bearing = wrap_angle(bearing + rng.normal(0.0, config.bearing_noise_std))
        if rng is not None and config.yaw_noise_std > 0.0:
            relative_yaw = wrap_angle(relative_yaw + rng.normal(0.0, config.yaw_noise_std))
        detections.append(FiducialDetectionData(entity.name, entity.kind, distance, bearing,
                                                distance * math.cos(bearing), distance * math.sin(bearing),
                                                relative_yaw))
    return FiducialReading(field_of_view=2.0 * half_fov, max_range=config.range, detections=tuple(detections))


def sense_laser(scene: Scene, robot: SimulatedMobileRobot, config: LaserConfig,
                rng: np.random.Generator | None = None) -> LaserReading:
    client = scene.client
    sx, sy, syaw = robot.pose2d(client)
    sz = _sensor_height(robot)
    angle_min, increment = laser_angles(config.fov_deg, config.beams)
    angles = angle_min + increment * np.arange(config.beams)
    directions = np.stack([np.cos(syaw + angles), np.sin(syaw + angles)], axis=1)
    start = robot.params.radius + RAY_START_CLEARANCE
    origin = np.array([sx, sy])
    rays_from = np.column_stack([origin + start * directions, np.full(config.beams, sz)])
    rays_to = np.column_stack([origin + config.range * directions, np.full(config.beams, sz)])
    ranges = np.full(config.beams, np.inf)
    if config.range > start:
        hits = p.rayTestBatch(rays_from.tolist(), rays_to.tolist(), physicsClientId=client)
        for beam, hit in enumerate(hits):
            if hit[0] >= 0:
                ranges[beam] = start + hit[2] * (config.range - start)
    range_min = robot.params.radius
    if rng is not None and config.noise_std > 0.0:
        finite = np.isfinite(ranges)
        ranges[finite] = np.clip(ranges[finite] + rng.normal(0.0, config.noise_std, finite.sum()),
                                 range_min, config.range)
    return LaserReading(angle_min=float(angle_min), angle_max=float(angles[-1]),
                        angle_increment=float(increment), range_min=range_min, range_max=config.range,
                        ranges=ranges)


def sense_gps(scene: Scene, robot: SimulatedMobileRobot, config: GpsConfig,
              rng: np.random.Generator | None = None) -> GpsReading:
    x, y, yaw = robot.pose2d(scene.client)
    if rng is not None:
        if config.noise_std > 0.0:
            x, y = x + rng.normal(0.0, config.noise_std), y + rng.normal(0.0, config.noise_std)
        if config.yaw_noise_std > 0.0:
            yaw = wrap_angle(yaw + rng.normal(0.0, config.yaw_noise_std))
    return GpsReading(x=float(x), y=float(y), yaw=float(yaw), position_std=config.noise_std,
                      yaw_std=config.yaw_noise_std)


def sense_bumper(scene: Scene, robot: SimulatedMobileRobot, config: BumperConfig) -> BumperReading:
    client = scene.client
    sx, sy, syaw = robot.pose2d(client)
    half_fov = math.radians(config.fov_deg) / 2.0
    entity_of = _entity_of_body(scene)
    points: dict[str, list[tuple[float, float]]] = {}
    touched: dict[str, SceneEntity] = {}
    for contact in p.getContactPoints(bodyA=robot.main_body, physicsClientId=client):
        other, position_on_robot, distance = contact[2], contact[5], contact[8]
        if distance > BUMPER_CONTACT_DISTANCE or scene.label_of_body(other) == BACKGROUND_LABEL:
            continue  # the ground plane, or a body only near the robot
        entity = entity_of.get(other)
        if entity is None or entity is robot:
            continue
        touched[entity.name] = entity
        points.setdefault(entity.name, []).append(position_on_robot[:2])
    contacts = []
    for name, entity in touched.items():
        mean_x, mean_y = np.mean(points[name], axis=0)
        bearing = wrap_angle(math.atan2(mean_y - sy, mean_x - sx) - syaw)
        if abs(bearing) <= half_fov + 1e-12:
            contacts.append(BumperContactData(name, entity.kind, bearing))
    return BumperReading(contacts=tuple(contacts))

"""What a team's sensors retrieve from the robots' poses: the geometric sensing model of Fig. 7.

Paper: Section V-A-2 and Fig. 7 (``shared/papers/iq_asymtre_coalitions.txt``): "The FOVs of the
fiducial sensors are restricted to be 180 deg facing forward with a maximum range of 4 m" -- a
fiducial retrieves the relative position F_R(X, local) of every robot X inside its field of view
and range, and capability sharing is possible only in that configuration. This module is that
model as a :class:`~.coalition_search.SensingModel` for :class:`~.coalition_search.CoalitionSearch`:

* :class:`FieldOfView` -- a sensor's field of view (centred on the robot's heading) and range;
* :class:`GeometricSensing` -- the readings of every robot's sensors over fixed poses (no
  occlusion, no noise: the bridge's ray-tested fiducials replace it in simulation);
* :func:`configuration_blind` -- every geometric sensor sees every robot: what approaches that
  know only the robot types (Table IV) assume, giving Table V's "possible" coalitions.

Pure: no simulator, no ROS.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping

from .capabilities import RobotCapabilities
from .errors import ConfigError
from .information import Entity, InformationInstance
from .requests import to_absolute


@dataclass(frozen=True)
class Pose:
    """A robot's position (m), heading (deg, 0 = +x, counter-clockwise) and its label in plots."""

    x: float
    y: float
    heading_deg: float
    label: str


@dataclass(frozen=True)
class FieldOfView:
    """A geometric sensor's field of view (centred on the heading) and range."""

    fov_deg: float
    range_m: float

    def contains(self, pose: Pose, x: float, y: float) -> bool:
        dx, dy = x - pose.x, y - pose.y
        if math.hypot(dx, dy) > self.range_m:
            return False
        bearing = math.degrees(math.atan2(dy, dx)) - pose.heading_deg
        bearing = (bearing + 180.0) % 360.0 - 180.0
        return abs(bearing) <= self.fov_deg / 2.0 + 1e-9


class GeometricSensing:
    """What each robot's sensors retrieve from the robots' poses (a ``SensingModel``).

    A sensor whose label has one variable (fiducial: ``F_R(X, local)``) retrieves it for every
    other robot inside its field of view and range (no occlusion, no noise; the bridge replaces
    this model in simulation). A sensor whose label has no variable (laser ``F_A(local)``,
    localization ``F_G(local)``) always retrieves it.
    """

    def __init__(self, team: Mapping[str, RobotCapabilities], poses: Mapping[str, Pose],
                 fields_of_view: Mapping[str, FieldOfView]):
        self.team = team
        self.poses = poses
        self.fields_of_view = fields_of_view
        self._table: dict[str, dict[str, tuple[InformationInstance, ...]]] = {}
        for robot, capabilities in team.items():
            if robot not in poses:
                raise ConfigError(f'robots.{robot}: no pose for this robot')
            per_sensor: dict[str, list[InformationInstance]] = {}
            for sensor in capabilities.sensors:
                per_sensor.setdefault(sensor.sensor, []).extend(self._retrieve(robot, sensor.sensor, sensor.output))
            self._table[robot] = {name: tuple(found) for name, found in per_sensor.items()}

    def _retrieve(self, robot: str, sensor: str, label: InformationInstance) -> list[InformationInstance]:
        variables = label.variables
        if not variables:
            return [to_absolute(label, robot)]
        if len(variables) > 1:
            raise ConfigError(f'sensors.{sensor}: the geometric model senses one entity at a time; '
                              f'{label} has {len(variables)} variables')
        if sensor not in self.fields_of_view:
            raise ConfigError(f'sensors.{sensor}: missing field of view (robot {robot}\'s {sensor} retrieves '
                              f'{label}, which depends on what it sees: give fov_deg and range_m)')
        view = self.fields_of_view[sensor]
        pose = self.poses[robot]
        return [to_absolute(label.substitute({variables[0]: Entity(other, robot=True)}), robot)
                for other in self.team if other != robot
                and view.contains(pose, self.poses[other].x, self.poses[other].y)]

    def readings(self, robot: str, sensor: str) -> tuple[InformationInstance, ...]:
        return self._table.get(robot, {}).get(sensor, ())

    def sightings(self) -> list[tuple[str, str, str]]:
        """(observer, seen robot, sensor) for every geometric reading."""
        found = []
        for robot, per_sensor in self._table.items():
            for sensor, instances in per_sensor.items():
                if sensor not in self.fields_of_view:
                    continue
                for instance in instances:
                    seen = [r.name for r in instance.referents if isinstance(r, Entity) and r.name != robot]
                    found.extend((robot, other, sensor) for other in seen)
        return found


def configuration_blind(fields_of_view: Mapping[str, FieldOfView]) -> dict[str, FieldOfView]:
    """Every geometric sensor sees every robot: what approaches using only Table IV assume."""
    return {sensor: FieldOfView(360.0, math.inf) for sensor in fields_of_view}


__all__ = ['FieldOfView', 'GeometricSensing', 'Pose', 'configuration_blind']

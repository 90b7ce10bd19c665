"""What a team's sensors retrieve from the robots' poses: the geometric sensing model of Fig. 7.

Paper (IQ-ASyMTRe, CITATION.cff): Section V-A-2 and Fig. 7: "The FOVs of the
fiducial sensors are restricted to be 180 deg facing forward with a maximum range of 4 m" -- a
fiducial retrieves the relative position F_R(X, local) of every robot X inside its field of view
and range, and capability sharing is possible only in that configuration. This module is that
model as a :class:`~.coalition_search.SensingModel` for :class:`~.coalition_search.CoalitionSearch`:

* :class:`FieldOfView` -- a sensor's field of view (centred on the robot's heading) and range;
* :class:`GeometricSensing` -- the readings of every robot's sensors over fixed poses, with
  line-of-sight occlusion by obstacle boxes (and, optionally, by the other robots' bodies), no
  noise: the bridge's ray-tested fiducials replace it in simulation;
* :func:`configuration_blind` -- every geometric sensor sees every robot: what approaches that
  know only the robot types (Table IV) assume, giving Table V's "possible" coalitions
  (``GeometricSensing(..., blind=True)`` does the same whatever the robots' own sensor views).

Visibility is the rule the bridge's simulated fiducial applies (``collab_tools.core.visibility``,
one module for both): in range centre to centre, bearing within fov/2 of the heading (edges
included, same tolerance), and the segment between the two centres meets no obstacle taller than
the sensor (closed boxes: touching blocks) and, with ``robot_radius_m``, passes no third robot's
disc. Where the two can differ (a line of sight grazing a box within
``GRAZING_TOLERANCE_M``; bodies the bridge has and the scenario does not name) is documented
in that module. A sensor's field of view is per robot (its type's sensor entry in the team file,
:meth:`~.capabilities.RobotCapabilities.sensor_view`); ``fields_of_view`` gives defaults per
sensor name for robots whose type names none.

Pure: no simulator, no ROS.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping, Sequence

from collab_tools.core.visibility import Box, in_field_of_view, line_of_sight_clear, segment_meets_disc

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
        """Range and field of view only (the shared rule, ``visibility.in_field_of_view``)."""
        return in_field_of_view(x - pose.x, y - pose.y, math.radians(pose.heading_deg), self.fov_deg, self.range_m)


#: The view of a sensor that ignores the configuration (every bearing, any distance).
BLIND_VIEW = FieldOfView(360.0, math.inf)


class GeometricSensing:
    """What each robot's sensors retrieve from the robots' poses (a ``SensingModel``).

    A sensor whose label has one variable (fiducial: ``F_R(X, local)``) retrieves it for every
    other robot inside its field of view and range whose line of sight is clear of ``obstacles``
    (boxes already reduced to those taller than the sensor) and, when ``robot_radius_m`` is given,
    of the other robots' discs (no noise; the bridge replaces this model in simulation). A sensor
    whose label has no variable (laser ``F_A(local)``, localization ``F_G(local)``) always
    retrieves it. ``blind``: every geometric sensor sees every robot (no FOV, range or occlusion).
    """

    def __init__(self, team: Mapping[str, RobotCapabilities], poses: Mapping[str, Pose],
                 fields_of_view: Mapping[str, FieldOfView], obstacles: Sequence[Box] = (),
                 robot_radius_m: float | None = None, blind: bool = False):
        self.team = team
        self.poses = poses
        self.fields_of_view = fields_of_view
        self.obstacles = tuple(obstacles)
        self.robot_radius_m = robot_radius_m
        self.blind = blind
        self._geometric: set[str] = set()
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
        self._geometric.add(sensor)
        view = self.view_of(robot, sensor, label)
        return [to_absolute(label.substitute({variables[0]: Entity(other, robot=True)}), robot)
                for other in self.team if other != robot and self.sees(robot, other, view)]

    def view_of(self, robot: str, sensor: str, label: object = None) -> FieldOfView:
        """``robot``'s ``sensor`` field of view: its own (team file), else the default for the sensor."""
        if self.blind:
            return BLIND_VIEW
        own = self.team[robot].sensor_view(sensor)
        if own is not None:
            return FieldOfView(*own)
        if sensor not in self.fields_of_view:
            raise ConfigError(f'sensors.{sensor}: missing field of view (robot {robot}\'s {sensor} retrieves '
                              f'{label}, which depends on what it sees: give fov_deg and range_m in its type\'s '
                              f'sensor entry of the team file)')
        return self.fields_of_view[sensor]

    def sees(self, robot: str, other: str, view: FieldOfView) -> bool:
        """Whether ``robot``'s sensor with ``view`` sees ``other`` (FOV, range, line of sight)."""
        pose, target = self.poses[robot], self.poses[other]
        if not view.contains(pose, target.x, target.y):
            return False
        if self.blind:
            return True
        segment = ((pose.x, pose.y), (target.x, target.y))
        if not line_of_sight_clear(segment, self.obstacles):
            return False
        if self.robot_radius_m is None:
            return True
        return not any(segment_meets_disc(*segment, (self.poses[third].x, self.poses[third].y), self.robot_radius_m)
                       for third in self.team if third not in (robot, other))

    @property
    def geometric_sensors(self) -> frozenset[str]:
        """The sensors whose readings depend on what they see (a label with a variable)."""
        return frozenset(self._geometric)

    def readings(self, robot: str, sensor: str) -> tuple[InformationInstance, ...]:
        return self._table.get(robot, {}).get(sensor, ())

    def sightings(self) -> list[tuple[str, str, str]]:
        """(observer, seen robot, sensor) for every geometric reading."""
        found = []
        for robot, per_sensor in self._table.items():
            for sensor, instances in per_sensor.items():
                if sensor not in self._geometric:
                    continue
                for instance in instances:
                    seen = [r.name for r in instance.referents if isinstance(r, Entity) and r.name != robot]
                    found.extend((robot, other, sensor) for other in seen)
        return found


def configuration_blind(fields_of_view: Mapping[str, FieldOfView]) -> dict[str, FieldOfView]:
    """Every geometric sensor sees every robot: what approaches using only Table IV assume (default
    views only: a robot's own view in the team file wins; ``GeometricSensing(blind=True)`` ignores both)."""
    return {sensor: FieldOfView(360.0, math.inf) for sensor in fields_of_view}


__all__ = ['BLIND_VIEW', 'FieldOfView', 'GeometricSensing', 'Pose', 'configuration_blind']

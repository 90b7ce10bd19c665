"""What a robot's sensors retrieve now, from live sensor reports (a ``SensingModel``).

:class:`~.coalition_search.StaticSensing` is a fixed table and the experiments' geometric model
computes readings from poses; on the robot the readings come from its active sensors. A report
names what the sensor perceived: for a sensor whose label has one variable (a fiducial,
``F_R(X, local)``) the entities it detects -- each detected team robot or library object gives
one instance, ``F_R(robot_2, robot_1)``; other detections (a target the library does not name)
are ignored; for a sensor whose label has no variable (GPS ``F_G(local)``, laser ``F_A(local)``)
a report means the information is retrieved.

Choice (the paper is silent): a reading is current for ``timeout_s`` after the sensor's last
report; a new report of a sensor replaces its readings (a fiducial that stops seeing a robot
stops providing F_R for it).

A report may also carry the readings' values (``values``: per detected name for a one-variable
sensor, one value otherwise; the planar values of :mod:`.value_fields`): what a coalition
streams and its motor schema uses while it executes (:meth:`LiveSensing.value`). A fiducial
marker gives the seen entity's orientation as well as its position (the bridge's
``FiducialDetection.yaw``): :func:`fiducial_values` keeps it as the F_R value's ``yaw``, so the
RPSs that need a relative heading (inverting F_R, composing F_R, F_G through a fiducial) are
computed from it rather than from a heading estimate.
"""
from __future__ import annotations

import math
from typing import Iterable, Mapping

from .capabilities import RobotCapabilities
from .errors import ConfigError
from .information import Entity, InformationInstance
from .value_fields import check_value
from .requests import to_absolute


def fiducial_values(detections: Iterable[tuple[str, float, float, float]],
                    ) -> tuple[list[str], dict[str, dict[str, float]]]:
    """(detected names, F_R value per name) of one fiducial report given as (name, x, y, yaw):
    the seen entity's position in the sensing robot's frame and its heading relative to the
    sensing robot's (rad, wrapped to (-pi, pi]). A non-finite number is kept and rejected by
    :meth:`LiveSensing.report`, naming the field."""
    names, values = [], {}
    for name, x, y, yaw in detections:
        names.append(name)
        yaw = float(yaw)
        values[name] = {'x': float(x), 'y': float(y),
                        'yaw': math.atan2(math.sin(yaw), math.cos(yaw)) if math.isfinite(yaw) else yaw}
    return names, values


class LiveSensing:
    """Readings of one robot's sensors from their latest reports (see the module docstring)."""

    def __init__(self, robot: str, capabilities: RobotCapabilities, robots: Iterable[str],
                 objects: Iterable[str] = (), timeout_s: float = 1.0):
        if not timeout_s > 0:
            raise ConfigError(f'reading_timeout: must be > 0 s (got {timeout_s!r})')
        self.robot = robot
        self.labels: dict[str, list[InformationInstance]] = {}
        for sensor in capabilities.sensors:
            if len(sensor.output.variables) > 1:
                raise ConfigError(f'sensors.{sensor.sensor}: a live sensor reports one entity per detection; '
                                  f'{sensor.output} has {len(sensor.output.variables)} variables')
            self.labels.setdefault(sensor.sensor, []).append(sensor.output)
        self.entities: dict[str, Entity] = {name: Entity(name, robot=True) for name in robots}
        self.entities.update({name: Entity(name, robot=False) for name in objects})
        self.timeout_s = timeout_s
        self._reports: dict[str, tuple[tuple[InformationInstance, ...], float]] = {}
        self._values: dict[InformationInstance, tuple[dict, float]] = {}

    @property
    def sensors(self) -> tuple[str, ...]:
        return tuple(self.labels)

    def report(self, sensor: str, now: float, detected: Iterable[str] = (),
               values: Mapping[str, Mapping[str, float]] | Mapping[str, float] | None = None,
               ) -> tuple[InformationInstance, ...]:
        """Record a report of ``sensor`` at ``now``; ``detected`` names what a one-variable sensor
        saw; ``values`` (optional) their values by name, or the one value of a sensor whose label
        has no variable. Returns the instances retrieved."""
        if sensor not in self.labels:
            raise ConfigError(f"sensor '{sensor}': {self.robot} has no such sensor (sensors: {', '.join(self.labels)})")
        names = list(dict.fromkeys(detected))
        found: list[InformationInstance] = []
        for label in self.labels[sensor]:
            variables = label.variables
            if not variables:
                instance = to_absolute(label, self.robot)
                found.append(instance)
                if values is not None:
                    self._values[instance] = (check_value(instance.label, values, f'{sensor} value'), now)
                continue
            for name in names:
                entity = self.entities.get(name)
                if entity is None or name == self.robot:
                    continue
                instance = to_absolute(label.substitute({variables[0]: entity}), self.robot)
                if not instance.is_degenerate:
                    found.append(instance)
                    if values is not None and name in values:
                        self._values[instance] = (check_value(instance.label, values[name],
                                                              f'{sensor} value of {name}'), now)
        readings = tuple(dict.fromkeys(found))
        self._reports[sensor] = (readings, now)
        return readings

    def current(self, now: float) -> dict[str, tuple[InformationInstance, ...]]:
        """sensor -> instances of every sensor reported within ``timeout_s`` of ``now``."""
        return {sensor: readings for sensor, (readings, stamp) in self._reports.items()
                if now - stamp <= self.timeout_s}

    def value(self, instance: InformationInstance, now: float) -> dict | None:
        """The current value of one of this robot's readings (None: none, or older than the
        timeout, or no longer reported: a fiducial that stopped seeing the entity)."""
        kept = self._values.get(instance)
        if kept is None or now - kept[1] > self.timeout_s:
            return None
        for sensor, (readings, _) in self._reports.items():
            if instance in readings:
                return kept[0]
        return None

    def readings(self, robot: str, sensor: str, now: float | None = None) -> tuple[InformationInstance, ...]:
        """The SensingModel interface (``now`` None: the latest report, however old)."""
        if robot != self.robot or sensor not in self._reports:
            return ()
        readings, stamp = self._reports[sensor]
        return readings if now is None or now - stamp <= self.timeout_s else ()



__all__ = ['LiveSensing', 'fiducial_values']

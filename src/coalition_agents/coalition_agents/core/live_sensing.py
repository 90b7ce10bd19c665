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
"""
from __future__ import annotations

from typing import Iterable

from .capabilities import RobotCapabilities
from .errors import ConfigError
from .information import Entity, InformationInstance
from .requests import to_absolute


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

    @property
    def sensors(self) -> tuple[str, ...]:
        return tuple(self.labels)

    def report(self, sensor: str, now: float, detected: Iterable[str] = ()) -> tuple[InformationInstance, ...]:
        """Record a report of ``sensor`` at ``now``; ``detected`` names what a one-variable sensor
        saw. Returns the instances retrieved."""
        if sensor not in self.labels:
            raise ConfigError(f"sensor '{sensor}': {self.robot} has no such sensor (sensors: {', '.join(self.labels)})")
        names = list(dict.fromkeys(detected))
        found: list[InformationInstance] = []
        for label in self.labels[sensor]:
            variables = label.variables
            if not variables:
                found.append(to_absolute(label, self.robot))
                continue
            for name in names:
                entity = self.entities.get(name)
                if entity is None or name == self.robot:
                    continue
                instance = to_absolute(label.substitute({variables[0]: entity}), self.robot)
                if not instance.is_degenerate:
                    found.append(instance)
        readings = tuple(dict.fromkeys(found))
        self._reports[sensor] = (readings, now)
        return readings

    def current(self, now: float) -> dict[str, tuple[InformationInstance, ...]]:
        """sensor -> instances of every sensor reported within ``timeout_s`` of ``now``."""
        return {sensor: readings for sensor, (readings, stamp) in self._reports.items()
                if now - stamp <= self.timeout_s}

    def readings(self, robot: str, sensor: str, now: float | None = None) -> tuple[InformationInstance, ...]:
        """The SensingModel interface (``now`` None: the latest report, however old)."""
        if robot != self.robot or sensor not in self._reports:
            return ()
        readings, stamp = self._reports[sensor]
        return readings if now is None or now - stamp <= self.timeout_s else ()



__all__ = ['LiveSensing']

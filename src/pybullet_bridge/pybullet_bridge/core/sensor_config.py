"""The ``sensors`` field of a mobile robot: which simulated sensors it carries, and how.

IQ-ASyMTRe (Sec. V) equips robots with a fiducial sensor (limited field of view and
range, e.g. 180 deg / 4 m), a laser, a GPS-like localisation sensor and a bumper; a
schema agent activates a sensor (an ES-EPS pair) only while it needs its information.
Each robot lists the sensors it has, at most one of each kind, under its own name
(``fiducial``, ``laser``, ``gps``, ``bumper``), which is also the name the on/off
service takes. Every sensor has ``active`` (default true: publishing from the start)
and a ``rate`` in Hz of simulated time. The sensors sit at the robot's centre and look
along its heading (frames ``<robot>/<sensor>_link``, fixed to ``<robot>/base_link``: core/frames.py).

Noise is Gaussian, drawn from one generator per sensor seeded from ``sensors.seed``
(default: derived from the scenario seed and the robot's index), so a run repeats
exactly. Where the paper is silent (rates, noise, laser layout) the defaults are those
of the sensors it names: a 180-beam laser over 180 deg, 10 Hz everywhere.

This module only parses and validates; :mod:`.sensors` does the sensing.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from collab_tools.core.fields import Fields, fail, join_path, require_list
from collab_tools.core.settings import echo

from .errors import ScenarioError

FIDUCIAL, LASER, GPS, BUMPER = 'fiducial', 'laser', 'gps', 'bumper'
SENSOR_NAMES = (FIDUCIAL, LASER, GPS, BUMPER)
#: Entity kinds that carry a fiducial marker (robots, targets, pushable boxes).
FIDUCIAL_KINDS = ('mobile_robot', 'target', 'movable_box')
DEFAULT_RATE = 10.0   # Hz of simulated time
MAX_RATE = 100.0
MAX_LASER_BEAMS = 2048
#: Keeps robots' sensor seeds apart from other seeded things (arms use spawn keys (index,)).
_SENSOR_SEED_DOMAIN = 0x5E45


@dataclass(frozen=True)
class FiducialConfig:
    fov_deg: float             # full opening angle, centred on the heading
    range: float               # m, centre to centre
    rate: float
    range_noise_std: float     # m
    bearing_noise_std: float   # rad
    yaw_noise_std: float       # rad, on the marker's relative orientation
    kinds: tuple[str, ...]     # entity kinds it detects
    active: bool


@dataclass(frozen=True)
class LaserConfig:
    fov_deg: float
    beams: int
    range: float               # m, maximum range
    rate: float
    noise_std: float           # m, added to every return
    active: bool


@dataclass(frozen=True)
class GpsConfig:
    rate: float
    noise_std: float           # m, per axis
    yaw_noise_std: float       # rad
    active: bool


@dataclass(frozen=True)
class BumperConfig:
    rate: float
    fov_deg: float             # contacts outside this arc around the heading are not felt
    active: bool


SensorConfig = FiducialConfig | LaserConfig | GpsConfig | BumperConfig


@dataclass(frozen=True)
class SensorSet:
    """The sensors of one robot, by name, in :data:`SENSOR_NAMES` order."""

    seed: int
    sensors: dict[str, SensorConfig]

    def __contains__(self, name: str) -> bool:
        return name in self.sensors

    def __getitem__(self, name: str) -> SensorConfig:
        return self.sensors[name]

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self.sensors)


def derived_sensor_seed(scenario_seed: int | None, robot_index: int) -> int:
    """Seed of robot ``robot_index``'s sensors when it gives none: reproducible, distinct per robot."""
    entropy = 0 if scenario_seed is None else scenario_seed
    sequence = np.random.SeedSequence(entropy=entropy, spawn_key=(_SENSOR_SEED_DOMAIN, robot_index))
    return int(sequence.generate_state(1)[0])


def _active(fields: Fields) -> bool:
    value = fields.raw('active', True)
    if not isinstance(value, bool):
        raise fail(fields.path_of('active'), f'must be true or false (got {echo(value)})', error=ScenarioError)
    return value


def _rate(fields: Fields) -> float:
    return fields.number('rate', DEFAULT_RATE, gt=0.0, le=MAX_RATE)


def _parse_fiducial(value: Any, path: str) -> FiducialConfig:
    fields = Fields({} if value is None else value, path, allowed=(
        'fov_deg', 'range', 'rate', 'range_noise_std', 'bearing_noise_std', 'yaw_noise_std', 'kinds', 'active'), error=ScenarioError)
    kinds = FIDUCIAL_KINDS
    if fields.has('kinds'):
        kinds_path = fields.path_of('kinds')
        kinds = tuple(require_list(fields.raw('kinds'), kinds_path, error=ScenarioError))
        for index, kind in enumerate(kinds):
            if kind not in FIDUCIAL_KINDS:
                raise fail(join_path(kinds_path, index), f'unknown kind {echo(kind)} '
                           f"(allowed: {', '.join(FIDUCIAL_KINDS)})", error=ScenarioError)
    return FiducialConfig(
        # The paper's Fig. 7 fiducials: 180 deg facing forward, 4 m.
        fov_deg=fields.number('fov_deg', 180.0, gt=0.0, le=360.0),
        range=fields.number('range', 4.0, gt=0.0, le=100.0),
        rate=_rate(fields),
        range_noise_std=fields.number('range_noise_std', 0.0, ge=0.0),
        bearing_noise_std=fields.number('bearing_noise_std', 0.0, ge=0.0),
        yaw_noise_std=fields.number('yaw_noise_std', 0.0, ge=0.0),
        kinds=kinds, active=_active(fields))


def _parse_laser(value: Any, path: str) -> LaserConfig:
    fields = Fields({} if value is None else value, path, allowed=(
        'fov_deg', 'beams', 'range', 'rate', 'noise_std', 'active'), error=ScenarioError)
    return LaserConfig(
        fov_deg=fields.number('fov_deg', 180.0, gt=0.0, le=360.0),
        beams=fields.integer('beams', 181, ge=1, le=MAX_LASER_BEAMS),
        range=fields.number('range', 8.0, gt=0.0, le=100.0),
        rate=_rate(fields), noise_std=fields.number('noise_std', 0.0, ge=0.0), active=_active(fields))


def _parse_gps(value: Any, path: str) -> GpsConfig:
    fields = Fields({} if value is None else value, path, allowed=(
        'rate', 'noise_std', 'yaw_noise_std', 'active'), error=ScenarioError)
    return GpsConfig(rate=_rate(fields), noise_std=fields.number('noise_std', 0.0, ge=0.0),
                     yaw_noise_std=fields.number('yaw_noise_std', 0.0, ge=0.0), active=_active(fields))


def _parse_bumper(value: Any, path: str) -> BumperConfig:
    fields = Fields({} if value is None else value, path, allowed=('rate', 'fov_deg', 'active'), error=ScenarioError)
    return BumperConfig(rate=_rate(fields), fov_deg=fields.number('fov_deg', 360.0, gt=0.0, le=360.0),
                        active=_active(fields))


_PARSERS = {FIDUCIAL: _parse_fiducial, LASER: _parse_laser, GPS: _parse_gps, BUMPER: _parse_bumper}


def parse_robot_sensors(value: Any, path: str, scenario_seed: int | None,
                        robot_index: int) -> SensorSet | None:
    """Parse a robot's ``sensors`` mapping (``path`` is its dotted path); None means no sensors.

    A sensor given as ``{}`` or ``null`` gets every default.
    """
    if value is None:
        return None
    fields = Fields(value, path, allowed=('seed', *SENSOR_NAMES), error=ScenarioError)
    seed = fields.integer('seed') if fields.raw('seed', None) is not None else \
        derived_sensor_seed(scenario_seed, robot_index)
    sensors = {name: _PARSERS[name](fields.raw(name), fields.path_of(name))
               for name in SENSOR_NAMES if fields.has(name)}
    if not sensors:
        raise fail(path, f"lists no sensor (allowed: {', '.join(SENSOR_NAMES)}); "
                   'leave the field out for a robot without sensors', error=ScenarioError)
    return SensorSet(seed=seed, sensors=sensors)

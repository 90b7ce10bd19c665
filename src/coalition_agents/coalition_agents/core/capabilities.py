"""A robot's capabilities (sensors with their EPSs, own PSs, motor schemas) from YAML.

Capability file format (every field validated, unknown keys are errors)::

    robot_types:                  # required mapping: type name -> capabilities
      scout:                      # [A-Za-z][A-Za-z0-9_]*
        description: ''           # optional text
        sensors:                  # optional list of environmental sensors (ES)
          - name: fiducial        # required, unique in the type; 'prior' is reserved
            provides:             # required list: one ES-EPS pair per label this sensor's
              - F_R(X, local)     #   EPS retrieves (variables are instantiated by the reading)
            fov_deg: 180.0        # optional, (0, 360]: the sensor's field of view, centred on the
            range_m: 4.0          #   heading, and range (m, > 0), both or neither: what a sensor
                                  #   that senses other robots (a label with a variable) sees in
                                  #   the geometric model (core.geometric_sensing) and the
                                  #   generated bridge scenario; per robot type, so per robot
        perceptual_schemas:       # optional robot-specific PSs in IQ form (cost `ps`)
          - name: laser_localization           # unique, must not shadow a library RPS
            conversion: F_A(local) + F_M => F_G(local)
            description: ''
        motor_schemas: [navigate] # optional list of MSs this robot can activate
    robots:                       # optional mapping: robot name -> type name
      robot_1: scout              # robot names must not look like variables (not 'R1')

Labels use the library's information types and objects (``config/coalitions/schemas.yaml``).
The same document may come as text (:func:`capability_file_from_text`: a node's ``capabilities``
parameter), so a team generated for one run reaches its agents without a file.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

from collab_tools.core.fields import Fields, load_config_file, parse_yaml_text

from .errors import ConfigError, InformationError
from .information import check_entity_name
from .schemas import (
    Conversion, SchemaKind, SchemaLibrary, SensorSchema, check_listed_names, conversions_from_list,
    parse_field_instance,
)

#: The sensor name of task priors (dummy sensors of a priori information).
PRIOR_SENSOR = 'prior'


@dataclass(frozen=True)
class RobotCapabilities:
    """What one robot (type) can sense, convert and actuate."""

    name: str
    sensors: tuple[SensorSchema, ...] = ()
    perceptual_schemas: tuple[Conversion, ...] = ()
    motor_schemas: frozenset[str] = frozenset()
    description: str = ''
    #: (sensor, fov_deg, range_m) of the sensors whose entry gives a field of view
    sensor_views: tuple[tuple[str, float, float], ...] = ()

    def sensor_view(self, sensor: str) -> tuple[float, float] | None:
        """(fov_deg, range_m) of ``sensor`` when the team file gives them, else None."""
        return next(((fov, reach) for name, fov, reach in self.sensor_views if name == sensor), None)

    @property
    def reasoning_key(self) -> tuple:
        """What solution spaces depend on: robots with equal keys share generated spaces."""
        return (self.sensors, self.perceptual_schemas)

    @property
    def sensor_names(self) -> tuple[str, ...]:
        return tuple(dict.fromkeys(s.sensor for s in self.sensors))

    def with_sensors(self, extra: tuple[SensorSchema, ...]) -> 'RobotCapabilities':
        return RobotCapabilities(self.name, self.sensors + extra, self.perceptual_schemas,
                                 self.motor_schemas, self.description, self.sensor_views)


@dataclass(frozen=True)
class CapabilityFile:
    """Robot types of a capability file, and the robots it assigns to them."""

    types: Mapping[str, RobotCapabilities]
    robots: Mapping[str, RobotCapabilities]


def capabilities_from_dict(data: Any, library: SchemaLibrary, name: str, path: str) -> RobotCapabilities:
    section = Fields(data, path, ('description', 'sensors', 'perceptual_schemas', 'motor_schemas'), error=ConfigError)
    sensors: list[SensorSchema] = []
    sensor_names: set[str] = set()
    views: list[tuple[str, float, float]] = []
    for sensor_path, item in section.items('sensors', []):
        entry = Fields(item, sensor_path, ('name', 'provides', 'fov_deg', 'range_m'), error=ConfigError)
        sensor = entry.name('name')
        if sensor == PRIOR_SENSOR:
            raise ConfigError(f"{entry.path_of('name')}: '{PRIOR_SENSOR}' is reserved for a task's a priori information")
        if sensor in sensor_names:
            raise ConfigError(f"{entry.path_of('name')}: sensor '{sensor}' is listed twice")
        sensor_names.add(sensor)
        view = _sensor_view(entry)
        if view is not None:
            views.append((sensor, *view))
        labels = entry.items('provides')
        if not labels:
            raise ConfigError(f"{entry.path_of('provides')}: a sensor must provide at least one label")
        outputs = []
        for label_path, label in labels:
            output = parse_field_instance(library, label, label_path)
            if output in outputs:
                raise ConfigError(f'{label_path}: {output} is listed twice')
            outputs.append(output)
            sensors.append(SensorSchema(sensor, output))
    library_names = {c.name for c in library.reductions}
    own = conversions_from_list(section.items('perceptual_schemas', []), library.types, library.catalog,
                                SchemaKind.PS, taken=set())
    for index, conversion in enumerate(own):
        if conversion.name in library_names:
            raise ConfigError(f"{section.path_of('perceptual_schemas')}[{index}].name: '{conversion.name}' "
                              f"shadows a library RPS of the same name")
    motor = check_listed_names(section.items('motor_schemas', []))
    return RobotCapabilities(name, tuple(sensors), own, frozenset(motor),
                             section.string('description', '', allow_empty=True), tuple(views))


def _sensor_view(entry: Fields) -> tuple[float, float] | None:
    """A sensor entry's (fov_deg, range_m), both or neither."""
    given = [key for key in ('fov_deg', 'range_m') if entry.raw(key, None) is not None]
    if not given:
        return None
    if len(given) == 1:
        missing = 'range_m' if given[0] == 'fov_deg' else 'fov_deg'
        raise ConfigError(f'{entry.path_of(missing)}: required with {given[0]} (a field of view needs both)')
    fov = entry.number('fov_deg', gt=0.0)
    if fov > 360.0:
        raise ConfigError(f"{entry.path_of('fov_deg')}: must be in (0, 360] (got {fov})")
    return fov, entry.number('range_m', gt=0.0)


def capability_file_from_dict(data: Any, library: SchemaLibrary, path: str = '') -> CapabilityFile:
    section = Fields(data, path, ('robot_types', 'robots'), error=ConfigError)
    types = {name: capabilities_from_dict(value, library, name, entry_path)
             for entry_path, name, value in section.entries('robot_types')}
    if not types:
        raise ConfigError(f"{section.path_of('robot_types')}: define at least one robot type")
    robots: dict[str, RobotCapabilities] = {}
    for entry_path, robot, type_name in section.entries('robots', []):
        try:
            check_entity_name(robot)
        except InformationError as exc:
            raise ConfigError(f'{entry_path}: {exc}') from None
        if type_name not in types:
            raise ConfigError(f"{entry_path}: unknown robot type {type_name!r} "
                              f"(defined: {', '.join(sorted(types))})")
        robots[robot] = types[type_name]
    return CapabilityFile(types, robots)


def load_capability_file(path: str | Path, library: SchemaLibrary) -> CapabilityFile:
    """Read and validate a capability file (errors name the file and the field)."""
    return load_config_file(path, lambda data: capability_file_from_dict(data, library, ''), ConfigError)


def capability_file_from_text(text: str, library: SchemaLibrary) -> CapabilityFile:
    """Parse and validate a capability document given as YAML text (errors name the field; the
    caller names the text's origin, e.g. the parameter)."""
    return capability_file_from_dict(parse_yaml_text(text, ConfigError), library, '')

"""Simulated coalition scenarios as data: robot placements -> bridge scenario, team capability
file and the hosted agents' parameter file (used by the sim experiments, ``coalition_agents.experiments``).

* :func:`column_placements` -- the paper's Fig. 9 column (Section V-A-4): ``robots`` robots in a
  line along +x, all facing +x (the front), ``spacing_m`` apart; only the front robot (robot_1)
  localises. The fiducial's field of view and range are chosen by the caller so that each robot
  sees only the robot immediately ahead (range < 2 x spacing; the bridge's ray test adds the
  occlusion by the robot in between). The robot at the back (robot_N) runs the navigation task;
  every other robot is a helper.
* :func:`placements_from_poses` -- any layout given as poses (the Fig. 7 clusters of
  ``config/coalitions/scenarios/fig7.yaml``).
* :func:`bridge_scenario` -- the pybullet_bridge scenario (``config/scenarios`` format) of the
  placements: every robot with the bridge sensors its type has, all inactive (the agents switch on
  what their potential solutions need); a robot's fiducial takes its own field of view
  (:attr:`Placement.fiducial`, from its type's sensor entry) or the shared :class:`SensorSettings`;
  the scenario's obstacles ride along.
* :func:`parse_obstacles` -- a coalition scenario's ``obstacles`` section (the bridge's format:
  ``boxes`` and a ``map``, parsed by the bridge's own pure parser ``pybullet_bridge.core.obstacles``)
  as planar boxes for the geometric sensing model, and as the section the generated bridge
  scenario carries (image paths made absolute); :func:`check_footprints` refuses robots standing
  in an obstacle. Only boxes taller than the simulated robot's sensor (:data:`SENSOR_HEIGHT_M`)
  hide anything, in the bridge (its ray runs at half the robot's height) as in the core.
* :func:`capability_file` -- the team capability file (``config/coalitions/capabilities`` format)
  with the bridge's sensor names (``sensor_names`` renames, e.g. the paper's ``localization`` to
  the bridge's ``gps``).
* :func:`capability_text` -- that file as one line of YAML text: the agents' ``capabilities``
  parameter, so the generated team reaches agents on any machine without a file.
* :func:`agent_parameter_file` -- the ROS 2 parameter file (content) of the schema_agent nodes: the
  experiment gives it to the agent processes as their parameters, no node reads a generated file.

Choices (the paper gives no geometry for Fig. 9): 1 m spacing, fiducial FOV 60 deg and range
1.5 m; robots of the Table IV types (type 2 in front, type 1 behind).
"""
from __future__ import annotations

import colorsys
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Sequence

import yaml
from collab_tools.core.errors import ConfigurationError
from pybullet_bridge.core.robot_types import BUILTIN_ROBOT_TYPES
from collab_tools.core.visibility import Box, boxes_above, point_in_box

from .errors import ConfigError

#: Sensors the bridge simulates (pybullet_bridge sensor names).
BRIDGE_SENSORS = ('fiducial', 'laser', 'gps', 'bumper')
#: The bridge robot type every generated robot is, its footprint radius and its sensors' height
#: (half the robot's height: where the bridge's fiducial and laser rays run).
SIM_ROBOT_TYPE = 'pioneer_3dx'
ROBOT_RADIUS_M = float(BUILTIN_ROBOT_TYPES[SIM_ROBOT_TYPE]['radius'])
SENSOR_HEIGHT_M = float(BUILTIN_ROBOT_TYPES[SIM_ROBOT_TYPE]['height']) / 2.0


@dataclass(frozen=True)
class Placement:
    """One robot: position (m), heading (deg, 0 = +x, counter-clockwise) and its type in the team."""

    robot: str
    x: float
    y: float
    heading_deg: float
    robot_type: str
    #: this robot's fiducial (fov_deg, range_m) when its type gives one (else SensorSettings')
    fiducial: tuple[float, float] | None = None


@dataclass(frozen=True)
class SensorSettings:
    """Bridge sensor settings shared by every robot that has the sensor."""

    fiducial_fov_deg: float = 180.0
    fiducial_range_m: float = 4.0
    rate_hz: float = 10.0
    laser_beams: int = 31
    laser_range_m: float = 6.0

    def __post_init__(self) -> None:
        if not 0.0 < self.fiducial_fov_deg <= 360.0:
            raise ConfigError(f'fiducial.fov_deg: must be in (0, 360] (got {self.fiducial_fov_deg})')
        for name, value in (('fiducial.range_m', self.fiducial_range_m), ('rate_hz', self.rate_hz),
                            ('laser.range_m', self.laser_range_m)):
            if not value > 0.0:
                raise ConfigError(f'{name}: must be > 0 (got {value})')
        if self.laser_beams < 1:
            raise ConfigError(f'laser.beams: must be >= 1 (got {self.laser_beams})')


#: Table IV's robot types with the bridge's sensor names.
COLUMN_TYPES = {
    'localizer': {'description': 'fiducial, laser, GPS, motor (Table IV type 2)',
                  'sensors': [{'name': 'fiducial', 'provides': ['F_R(X, local)']},
                              {'name': 'laser', 'provides': ['F_A(local)']},
                              {'name': 'gps', 'provides': ['F_G(local)']}],
                  'motor_schemas': ['navigate', 'maintain_relative_position']},
    'blind': {'description': 'fiducial, laser, motor; cannot localise (Table IV type 1)',
              'sensors': [{'name': 'fiducial', 'provides': ['F_R(X, local)']},
                          {'name': 'laser', 'provides': ['F_A(local)']}],
              'motor_schemas': ['navigate', 'maintain_relative_position']},
}


def column_placements(robots: int, spacing_m: float = 1.0) -> list[Placement]:
    """Fig. 9: robot_1 in front at x = 0 localises; robot_k stands (k-1) spacings behind it."""
    if isinstance(robots, bool) or not isinstance(robots, int) or robots < 2:
        raise ConfigError(f'robots: a column needs an integer >= 2 robots (got {robots!r})')
    if not spacing_m > 0.0:
        raise ConfigError(f'spacing_m: must be > 0 (got {spacing_m!r})')
    return [Placement(f'robot_{k}', -spacing_m * (k - 1), 0.0, 0.0, 'localizer' if k == 1 else 'blind')
            for k in range(1, robots + 1)]


def column_sees_only_the_robot_ahead(spacing_m: float, sensors: SensorSettings) -> bool:
    """Whether the fiducial reaches the robot ahead and (without counting occlusion) no further,
    and does not look behind."""
    return spacing_m <= sensors.fiducial_range_m < 2.0 * spacing_m and sensors.fiducial_fov_deg < 360.0


def placements_from_poses(poses: Mapping[str, tuple[float, float, float]], robot_types: Mapping[str, str],
                          fiducials: Mapping[str, tuple[float, float]] | None = None) -> list[Placement]:
    """Placements of ``robot -> (x, y, heading_deg)`` with each robot's type (and its own fiducial
    (fov_deg, range_m) where ``fiducials`` gives one)."""
    missing = [robot for robot in poses if robot not in robot_types]
    if missing:
        raise ConfigError(f'robots.{missing[0]}: no type for this robot')
    own = dict(fiducials or {})
    return [Placement(robot, float(x), float(y), float(h), robot_types[robot], own.get(robot))
            for robot, (x, y, h) in poses.items()]


@dataclass(frozen=True)
class Obstacles:
    """A scenario's obstacles: ``boxes`` (every one, for footprints) and ``occluding`` (taller
    than the sensor) for the sensing model; ``section``: the bridge's ``obstacles`` section."""

    boxes: tuple[Box, ...] = ()
    occluding: tuple[Box, ...] = ()
    section: Mapping[str, Any] | None = None


def parse_obstacles(value: Any, base_dir: Path, path: str = 'obstacles') -> Obstacles:
    """The ``obstacles`` section of a coalition scenario, in the bridge's format and parsed by the
    bridge's parser (errors name the field); relative image paths are relative to ``base_dir``."""
    if value is None:
        return Obstacles()
    from pybullet_bridge.core.obstacles import parse_obstacles as parse_bridge_obstacles
    from pybullet_bridge.core.sections import SectionContext
    from pybullet_bridge.core.world import WorldConfig
    world = WorldConfig('world', 0.004, -9.81, (-1e6, -1e6, 1e6, 1e6), None)
    try:
        definitions = parse_bridge_obstacles(value, SectionContext(path, Path(base_dir), world, {}, None))
    except ConfigurationError as exc:
        raise ConfigError(str(exc)) from None
    boxes = tuple(Box(d.center, d.size, d.yaw, d.height, d.name) for d in definitions)
    section = dict(value)
    if isinstance(section.get('map'), str):
        section['map'] = str((Path(base_dir) / section['map']).resolve())
    elif isinstance(section.get('map'), Mapping):
        section['map'] = {key: str((Path(base_dir) / item).resolve()) if key in ('image', 'yaml') else item
                          for key, item in section['map'].items()}
    return Obstacles(boxes, tuple(boxes_above(boxes, SENSOR_HEIGHT_M)), section)


def check_footprints(positions: Mapping[str, tuple[float, float]], obstacles: Obstacles,
                     radius_m: float = ROBOT_RADIUS_M) -> None:
    """Refuse a robot whose footprint disc overlaps an obstacle (the bridge would spawn it inside)."""
    for robot, position in positions.items():
        for box in obstacles.boxes:
            if point_in_box(position, box, radius_m):
                raise ConfigError(f'robots.{robot}.position: the robot\'s footprint (radius {radius_m} m) '
                                  f'overlaps obstacle {box.name!r} (centre {list(box.center)}, size {list(box.size)})')


def _colour(index: int, count: int) -> list[float]:
    # Hues spread around the circle: the bridge requires colours at least 0.1 apart.
    r, g, b = colorsys.hsv_to_rgb(index / max(count, 1), 0.75, 0.85 if index % 2 == 0 else 0.6)
    return [round(r, 3), round(g, 3), round(b, 3)]


def bridge_scenario(name: str, placements: Sequence[Placement], types: Mapping[str, Mapping],
                    sensors: SensorSettings, seed: int = 0, margin_m: float = 3.0,
                    obstacles: Mapping[str, Any] | None = None) -> dict:
    """The pybullet_bridge scenario of ``placements``; ``types`` are capability-file robot types
    whose sensor names are bridge sensors; ``obstacles``: the bridge's ``obstacles`` section
    (:attr:`Obstacles.section`)."""
    if not placements:
        raise ConfigError('robots: at least one robot')
    xs, ys = [p.x for p in placements], [p.y for p in placements]
    robots = []
    for index, placement in enumerate(placements):
        if placement.robot_type not in types:
            raise ConfigError(f'robots.{placement.robot}: unknown type {placement.robot_type!r} '
                              f'(types: {", ".join(types)})')
        section = {}
        for sensor in types[placement.robot_type]['sensors']:
            kind = sensor['name']
            if kind == 'fiducial':
                fov, reach = placement.fiducial or (sensors.fiducial_fov_deg, sensors.fiducial_range_m)
                section[kind] = {'fov_deg': fov, 'range': reach, 'rate': sensors.rate_hz, 'active': False}
            elif kind == 'laser':
                section[kind] = {'fov_deg': 180.0, 'beams': sensors.laser_beams, 'range': sensors.laser_range_m,
                                 'rate': sensors.rate_hz, 'active': False}
            elif kind in ('gps', 'bumper'):
                section[kind] = {'rate': sensors.rate_hz, 'active': False}
            else:
                raise ConfigError(f'robot_types.{placement.robot_type}.sensors: {kind!r} is not a bridge sensor '
                                  f'(allowed: {", ".join(BRIDGE_SENSORS)})')
        robots.append({'name': placement.robot, 'type': SIM_ROBOT_TYPE,
                       'pose': [placement.x, placement.y, round(math.radians(placement.heading_deg), 9)],
                       'color': _colour(index, len(placements)), 'sensors': section})
    scenario = {
        'name': name, 'seed': seed,
        'world': {'bounds': [min(xs) - margin_m, min(ys) - margin_m, max(xs) + margin_m, max(ys) + margin_m],
                  'walls': {'height': 0.3, 'thickness': 0.05}},
        'camera': {'frame_id': 'top_camera', 'rate': 1.0, 'width': 64, 'height': 64, 'altitude': 9.0},
        'mobile_robots': robots,
    }
    if obstacles:
        scenario['obstacles'] = dict(obstacles)
    return scenario


def capability_file(placements: Sequence[Placement], types: Mapping[str, Mapping],
                    sensor_names: Mapping[str, str] | None = None) -> dict:
    """The team capability file of ``placements``; ``sensor_names`` renames sensors (paper -> bridge)."""
    renames = dict(sensor_names or {})
    used = {p.robot_type for p in placements}
    robot_types = {}
    for name in sorted(used):
        if name not in types:
            raise ConfigError(f'robots: unknown robot type {name!r} (types: {", ".join(types)})')
        entry = dict(types[name])
        entry['sensors'] = [{**sensor, 'name': renames.get(sensor['name'], sensor['name'])}
                            for sensor in types[name]['sensors']]
        for sensor in entry['sensors']:
            if sensor['name'] not in BRIDGE_SENSORS:
                raise ConfigError(f'robot_types.{name}.sensors: {sensor["name"]!r} is not a bridge sensor (allowed: '
                                  f'{", ".join(BRIDGE_SENSORS)}; rename it with sensor_names)')
        robot_types[name] = entry
    return {'robot_types': robot_types, 'robots': {p.robot: p.robot_type for p in placements}}


def capability_text(team: Mapping) -> str:
    """A capability document (:func:`capability_file`) as one line of flow-style YAML: the value of
    the agents' ``capabilities`` parameter (a ROS parameter cannot hold lists of mappings)."""
    return yaml.safe_dump(team, default_flow_style=True, sort_keys=False, width=math.inf).strip()


def agent_parameter_file(common: Mapping[str, object], per_robot: Mapping[str, Mapping[str, object]],
                         node_name: str = 'schema_agent') -> dict:
    """ROS 2 parameter file for the schema_agent nodes: ``common`` for all, then per robot, keyed
    ``/**/<robot>/<node_name>`` (the node runs in its robot's namespace, which may itself sit
    under a session or team namespace)."""
    data: dict = {'/**': {'ros__parameters': dict(common)}}
    for robot, parameters in per_robot.items():
        data[f'/**/{robot}/{node_name}'] = {'ros__parameters': dict(parameters)}
    return data


__all__ = ['BRIDGE_SENSORS', 'COLUMN_TYPES', 'Obstacles', 'Placement', 'ROBOT_RADIUS_M', 'SENSOR_HEIGHT_M',
           'SIM_ROBOT_TYPE', 'SensorSettings', 'agent_parameter_file', 'bridge_scenario', 'capability_file',
           'capability_text', 'check_footprints', 'column_placements', 'column_sees_only_the_robot_ahead',
           'parse_obstacles', 'placements_from_poses']

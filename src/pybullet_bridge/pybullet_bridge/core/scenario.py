"""Scenario files: what the simulated world contains.

A scenario is a YAML mapping. Every field is validated; a mistake raises
:class:`ScenarioError` whose message starts with the dotted path of the field
(``mobile_robots[1].max_linear_velocity: must be > 0 (got -1.0)``). Unknown keys
are errors too, so typos never pass silently.

Schema (defaults shown; fields without a default are required)::

    name: demo_mobile                 # required, non-empty string
    seed: null                        # optional int: seed for any random choice
                                      # made by section parsers (none of the built-in ones are random)
    world:                            # optional section
      frame_id: world                 # frame of every published pose
      physics_dt: 0.004166667         # s, physics step, [1e-4, 0.05]
      gravity: -9.81                  # m/s^2 along z
      bounds: [-3.0, -3.0, 3.0, 3.0]  # xmin ymin xmax ymax (m), xmin < xmax, ymin < ymax
      walls: {height: 0.3, thickness: 0.05}
                                      # optional; null or absent = no walls. Walls stand just
                                      # outside bounds, so the whole bounds area stays free.
                                      # Both keys default to the values shown ({} is valid).
    camera:                           # optional section: top-view pinhole camera looking straight down
      frame_id: top_camera
      rate: 10.0                      # Hz of simulated time, (0, 100]
      width: 320                      # px, [16, 2048]
      height: 320                     # px, [16, 2048]
      center: [0.0, 0.0]              # x y (m) below the camera; default: centre of world.bounds
      altitude: 8.0                   # m above ground, > 0
      fov_deg: 45.0                   # vertical field of view (deg), (1, 170)
    robot_types:                      # optional. Built-ins pioneer_3dx and turtlebot3_burger
      my_type:                        # always exist; an entry with a new name must give every
        radius: 0.2                   # field below, an entry named like a built-in overrides
        height: 0.25                  # only the fields it lists. Type names match
        mass: 9.0                     # [A-Za-z][A-Za-z0-9_]*.
        max_linear_velocity: 1.0      # m/s, > 0
        max_angular_velocity: 3.0     # rad/s, > 0
        max_linear_acceleration: 1.0  # m/s^2, > 0
        max_angular_acceleration: 4.0 # rad/s^2, > 0
        command_timeout: 0.5          # s, > 0; a robot without a fresh command stops
                                      # (radius, height in m, > 0; mass in kg, > 0)
    mobile_robots:                    # optional list, one entry per differential-drive robot
      - name: robot_1                 # required, unique in the whole scene,
                                      # [A-Za-z][A-Za-z0-9_]* (it becomes a ROS namespace)
        type: pioneer_3dx             # required, a built-in or robot_types entry
        pose: [0.0, 0.0, 0.0]         # required, x y (m) yaw (rad); the robot's footprint
                                      # disc must lie inside world.bounds
        color: [0.9, 0.1, 0.1]        # required, r g b in [0, 1]; robots' colours must differ
                                      # by at least 0.1 (Euclidean) so the camera can tell them apart
        # any robot_types field may be overridden here, e.g. radius: 0.25
        sensors:                      # optional (core/sensor_config.py, core/sensors.py): the
                                      # simulated sensors the robot carries, at most one per kind;
                                      # each is listed by its name, {} takes every default. All sit at
                                      # the robot's centre facing its heading; every one has
                                      # active: true (publishing from the start; switchable at run
                                      # time) and rate: 10.0 (Hz of simulated time, (0, 100]).
          seed: null                  # int; default derived from the scenario seed and robot index
          fiducial:                   # detects robots, targets, movable boxes by name
            fov_deg: 180.0            # full opening angle (deg), (0, 360], centred on the heading
            range: 4.0                # m, centre to centre, (0, 100]
            range_noise_std: 0.0      # m, >= 0, added to the reported range
            bearing_noise_std: 0.0    # rad, >= 0, added to the reported bearing
            yaw_noise_std: 0.0        # rad, >= 0, added to the reported relative orientation
            kinds: [mobile_robot, target, movable_box]   # which kinds it detects
                                      # (seen = within range and FOV and in line of sight: a ray to
                                      # the entity's centre hits no other body first)
          laser: {fov_deg: 180.0, beams: 181, range: 8.0, noise_std: 0.0}
                                      # beams in [1, 2048]; range (m) in (0, 100]
          gps: {noise_std: 0.0, yaw_noise_std: 0.0}   # m per axis, rad
          bumper: {fov_deg: 360.0}    # contacts outside this arc around the heading are not felt
    obstacles:                        # optional, static obstacles
      boxes:                          # optional list
        - name: shelf                 # optional, default obstacle_<index>
          center: [1.0, 1.0]          # required, x y (m)
          size: [0.5, 0.3]            # required, sx sy (m), each > 0
          height: 0.3                 # m, > 0
          yaw: 0.0                    # rad
          color: [0.5, 0.5, 0.5]      # r g b in [0, 1]
      map:                            # optional occupancy image -> static boxes map_<index>
        image: ../maps/demo_map.png   # required, path relative to the scenario file
        resolution: 0.05              # required, m per pixel, > 0
        origin: [-3.0, -3.0]          # required, world x y of the image's bottom-left corner
        occupied_below: 128           # grey value (0..255) below which a pixel is occupied, [1, 256]
        height: 0.3                   # m, > 0
        color: [0.2, 0.2, 0.2]        # r g b in [0, 1]
    tables:                           # optional list of static tables (core/tabletop.py)
      - name: table                   # required, unique scene name
        center: [0.0, 0.0]            # required, x y (m)
        size: [0.3, 0.3]              # required, sx sy (m), each > 0; the top must lie inside
                                      # world.bounds and overlap no other table
        height: 0.4                   # required, z of the top surface (m), (0, 5]
        color: [0.78, 0.66, 0.5]      # r g b in [0, 1]
        grid: {rows: 3, cols: 3}      # optional: cells over the whole top, drawn as thin lines the
                                      # camera sees (visual only; cubes rest on the top itself).
                                      # rows, cols in [1, 100]; also line_width: 0.004 (m, < half
                                      # a cell) and color: [0.15, 0.15, 0.15]. Cell (row, col):
                                      # row 0 has the largest y, col 0 the smallest x.
    cubes:                            # optional list of dynamic cubes (core/tabletop.py)
      - name: red_1                   # required, unique scene name
        position: [-0.125, 0.125]     # required, x y (m); z follows from what is below: the
                                      # table whose top holds the whole footprint, else the ground
                                      # (then inside world.bounds). Straddling a table edge or
                                      # overlapping another cube or an obstacle is an error.
        size: 0.03                    # edge (m), (0, 0.5]
        mass: 0.05                    # kg, (0, 100]
        color: [0.85, 0.12, 0.12]     # required, r g b in [0, 1]
        yaw: 0.0                      # rad
    arms:                             # optional list of fixed-base arms (core/arm/)
      - name: leader_arm              # required, unique scene name (ROS namespace)
        model: panda                  # required: panda | kuka_iiwa | xarm6 (pybullet_data URDFs)
        base: [-0.565, 0.0, 0.0]      # required, x y (m) yaw (rad); the pedestal must lie inside
                                      # world.bounds and stand in no table or cube
        base_height: 0.0              # m, [0, 2]: top of the pedestal the arm stands on
                                      # (0 = on the ground); put it at table height for reach
        failure_probability: 0.0      # [0, 1]: chance that a task's grasp slips (drawn once per task)
        seed: null                    # int; default derived from the scenario seed and the arm's
                                      # index, so runs are reproducible
        max_joint_velocity: 1.5       # rad/s, (0, 10], also capped by each joint's URDF limit
        max_tool_speed: 0.4           # m/s of the tool on straight segments, (0, 2]
        phase_timeout: 2.0            # s of simulated time a motion segment may overrun, (0, 60]
        placement_clearance: 0.01     # m kept free around a placed cube, [0, 0.2]
        home: null                    # joint positions (rad), one per arm joint within the URDF
                                      # limits; default per model, out of the camera's view of
                                      # a table in front of the arm
    targets:                          # optional list of named markers fiducials detect (core/targets.py)
      - name: target_1                # required, unique scene name
        position: [1.0, 1.0]          # required, x y (m); the footprint must lie inside world.bounds
        radius: 0.05                  # m, (0, 1]: an upright cylinder with a collision shape
        height: 0.3                   # m, (0, 5]
        mass: 0.0                     # kg, [0, 1000]; 0 = static, > 0 = dynamic (can be pushed)
        color: [0.05, 0.05, 0.05]     # r g b in [0, 1]
    movable_boxes:                    # optional list of dynamic boxes robots push (core/movable_boxes.py)
      - name: box_1                   # required, unique scene name
        center: [0.5, 0.0]            # required, x y (m); the box must lie inside world.bounds
        size: [0.4, 0.4]              # sx sy (m), each in (0, 10]
        height: 0.3                   # m, (0, 5]
        mass: 2.0                     # kg, (0, 1000]
        friction: 0.5                 # box-ground Coulomb coefficient, [0, 10]
        yaw: 0.0                      # rad
        color: [0.55, 0.3, 0.7]       # r g b in [0, 1]

Any other top-level key must be a section: this module registers the built-in ones
(:data:`BUILTIN_SECTIONS`); a new kind registers itself with :func:`register_section`
without editing this module or the bridge loop. Section parsers return pure definitions
(no simulator); :class:`.scene.Scene` simulates them. Scene names must be unique across
all sections; ``walls`` is reserved when the world has walls.

Segmentation labels: 0 is the background (ground), the walls (if any) get 1,
then entities follow in section registration order (mobile_robots, obstacles,
tables, cubes, arms, targets, movable_boxes, later kinds) and in file order within a section. A section
parser sees the entities of the sections parsed before it in
``SectionContext.earlier`` (cubes check the tables under them).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Mapping

from collab_tools.core.fields import Fields, fail, join_path, read_yaml_file, type_name

from .arm.definition import parse_arms
from .errors import ScenarioError
from .mobile_robot import parse_mobile_robots
from .movable_boxes import parse_movable_boxes
from .obstacles import parse_obstacles
from .occupancy_map import MAX_MAP_BOXES
from .robot_types import BUILTIN_ROBOT_TYPES, ROBOT_TYPE_FIELDS, parse_robot_types
from .sections import (TOP_LEVEL_KEYS, SectionContext, SectionParser, register_section,
                       registered_sections, section_parsers, unregister_section)
from .tabletop import parse_cubes, parse_tables
from .targets import parse_targets
from .world import (DEFAULT_BOUNDS, DEFAULT_PHYSICS_DT, WALLS_ENTITY_NAME, CameraConfig, WallConfig,
                    WorldConfig, parse_camera, parse_world)

#: The built-in sections in label order (their parsers only validate: no simulator here).
BUILTIN_SECTIONS: tuple[tuple[str, SectionParser], ...] = (
    ('mobile_robots', parse_mobile_robots), ('obstacles', parse_obstacles), ('tables', parse_tables),
    ('cubes', parse_cubes), ('arms', parse_arms), ('targets', parse_targets),
    ('movable_boxes', parse_movable_boxes),
)
for _key, _parser in BUILTIN_SECTIONS:
    register_section(_key, _parser)

__all__ = [
    'BUILTIN_ROBOT_TYPES', 'BUILTIN_SECTIONS', 'DEFAULT_BOUNDS', 'DEFAULT_PHYSICS_DT', 'ROBOT_TYPE_FIELDS',
    'TOP_LEVEL_KEYS', 'WALLS_ENTITY_NAME', 'CameraConfig', 'Scenario', 'SectionContext', 'SectionParser',
    'WallConfig', 'WorldConfig', 'load_scenario', 'parse_scenario', 'register_section', 'registered_sections',
    'unregister_section',
]


@dataclass(frozen=True)
class Scenario:
    name: str
    source: Path | None
    world: WorldConfig
    camera: CameraConfig
    robot_types: dict[str, dict[str, float]]
    # sections[key] = definitions returned by that section's parser, in registration order
    sections: dict[str, list] = field(default_factory=dict)
    seed: int | None = None

    def entities(self) -> list:
        """Every section's entity definitions in spawn order."""
        return [entity for entities in self.sections.values() for entity in entities]


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario YAML file."""
    path = Path(path)
    data = read_yaml_file(path, 'scenario file', error=ScenarioError)
    try:
        return parse_scenario(data, path.resolve().parent, source=path.resolve())
    except ScenarioError as err:
        # Keep the field path first; name the file after it.
        raise ScenarioError(f'{err} (in {path})') from err


def parse_scenario(data: dict, base_dir: Path, source: Path | None = None) -> Scenario:
    """Validate a scenario already loaded from YAML; relative paths resolve against ``base_dir``."""
    parsers = section_parsers()
    if not isinstance(data, Mapping):
        raise ScenarioError(f'scenario: must be a mapping (got {type_name(data)})')
    for key in data:
        if key not in TOP_LEVEL_KEYS and key not in parsers:
            raise fail(str(key), 'unknown top-level field (known fields: '
                       f"{', '.join(TOP_LEVEL_KEYS)}; known sections: {', '.join(parsers)})", error=ScenarioError)
    top = Fields(data, '', allowed=list(data), error=ScenarioError)  # keys were checked above
    name = top.string('name')
    seed = None if data.get('seed') is None else top.integer('seed')
    world = parse_world(data.get('world'))
    camera = parse_camera(data.get('camera'), world)
    robot_types = parse_robot_types(data.get('robot_types'))

    sections: dict[str, list] = {}
    for key, parser in parsers.items():
        if key not in data:
            continue
        context = SectionContext(path=key, base_dir=Path(base_dir), world=world,
                                 robot_types=robot_types, seed=seed,
                                 earlier=MappingProxyType(dict(sections)))
        entities = list(parser(data[key], context))
        for index, entity in enumerate(entities):
            if not getattr(entity, 'config_path', ''):
                entity.config_path = join_path(key, index)
        sections[key] = entities
        count = sum(len(listed) for listed in sections.values())
        if count > MAX_MAP_BOXES:
            raise fail(key, f'the scene has more than {MAX_MAP_BOXES} entities ({count} with this section; the most '
                       'the simulator steps in real time, see core.occupancy_map.MAX_MAP_BOXES)', error=ScenarioError)
    _check_unique_names(sections, world)
    return Scenario(name=name, source=source, world=world, camera=camera,
                    robot_types=robot_types, sections=sections, seed=seed)


def _check_unique_names(sections: dict[str, list], world: WorldConfig) -> None:
    used_by: dict[str, str] = {}
    if world.walls is not None:
        used_by[WALLS_ENTITY_NAME] = 'world.walls'
    for entities in sections.values():
        for entity in entities:
            where = entity.config_path
            if entity.name in used_by:
                raise fail(join_path(where, 'name'),
                           f"duplicate name '{entity.name}' (also used by {used_by[entity.name]})", error=ScenarioError)
            used_by[entity.name] = where

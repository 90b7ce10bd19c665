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
      physics_dt: 0.004166667         # s, physics step, (0, 0.05]
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
    arms:                             # optional list of fixed-base arms (core/arm.py)
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

Any other top-level key must be a section registered with
:func:`register_section` (later work adds arms, cubes, sensors that way without
editing this module or the bridge loop). Scene names must be unique across all
sections; ``walls`` is reserved when the world has walls.

Segmentation labels: 0 is the background (ground), the walls (if any) get 1,
then entities follow in section registration order (mobile_robots, obstacles,
tables, cubes, arms, targets, movable_boxes, later kinds) and in file order within a section. A section
parser sees the entities of the sections parsed before it in
``SectionContext.earlier`` (cubes check the tables under them).
"""
from __future__ import annotations

import importlib
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import TYPE_CHECKING, Any, Callable, Mapping

from .errors import ScenarioError
from .fields import Fields, check_name, fail, join_path, read_yaml_file, require_mapping, type_name

if TYPE_CHECKING:
    from .scene import SceneEntity

#: Fields a robot type defines; each may be overridden per robot.
ROBOT_TYPE_FIELDS = (
    'radius', 'height', 'mass',
    'max_linear_velocity', 'max_angular_velocity',
    'max_linear_acceleration', 'max_angular_acceleration',
    'command_timeout',
)

BUILTIN_ROBOT_TYPES: dict[str, dict[str, float]] = {
    # Adept MobileRobots Pioneer 3-DX datasheet: 455 mm wide (radius ~0.228 m),
    # 237 mm tall, 9 kg, 1.2 m/s, 300 deg/s. The ARIA firmware default
    # accelerations (0.3 m/s^2, 100 deg/s^2) are sluggish for teleoperated
    # experiments, so we use the firmware's reachable 1.0 m/s^2 and 3.0 rad/s^2.
    'pioneer_3dx': {
        'radius': 0.23, 'height': 0.24, 'mass': 9.0,
        'max_linear_velocity': 1.2, 'max_angular_velocity': 5.24,
        'max_linear_acceleration': 1.0, 'max_angular_acceleration': 3.0,
        'command_timeout': 0.5,
    },
    # ROBOTIS TurtleBot3 Burger e-Manual: 138 x 178 x 192 mm, 1 kg,
    # 0.22 m/s, 2.84 rad/s; radius 0.105 m and the accelerations
    # (acc_lim_x 2.5, acc_lim_theta 3.2) are the turtlebot3_navigation2 burger values.
    'turtlebot3_burger': {
        'radius': 0.105, 'height': 0.192, 'mass': 1.0,
        'max_linear_velocity': 0.22, 'max_angular_velocity': 2.84,
        'max_linear_acceleration': 2.5, 'max_angular_acceleration': 3.2,
        'command_timeout': 0.5,
    },
}

DEFAULT_PHYSICS_DT = 1.0 / 240.0  # pybullet's own default step
DEFAULT_BOUNDS = (-3.0, -3.0, 3.0, 3.0)
TOP_LEVEL_KEYS = ('name', 'seed', 'world', 'camera', 'robot_types')
#: Modules whose import registers the built-in sections, in label order.
BUILTIN_SECTION_MODULES = ('.mobile_robot', '.obstacles', '.tabletop', '.arm', '.targets', '.movable_boxes')
#: Name of the wall entity the scene adds when world.walls is set.
WALLS_ENTITY_NAME = 'walls'


@dataclass(frozen=True)
class WallConfig:
    height: float
    thickness: float


@dataclass(frozen=True)
class WorldConfig:
    frame_id: str
    physics_dt: float
    gravity: float
    bounds: tuple[float, float, float, float]
    walls: WallConfig | None

    def contains(self, x: float, y: float, margin: float = 0.0) -> bool:
        """True if the disc of radius ``margin`` around (x, y) lies inside bounds."""
        xmin, ymin, xmax, ymax = self.bounds
        return xmin + margin <= x <= xmax - margin and ymin + margin <= y <= ymax - margin


@dataclass(frozen=True)
class CameraConfig:
    frame_id: str
    rate: float
    width: int
    height: int
    center: tuple[float, float]
    altitude: float
    fov_deg: float


@dataclass
class SectionContext:
    """What a section parser may need besides its own YAML value."""

    path: str                       # dotted path of the section, e.g. 'mobile_robots'
    base_dir: Path                  # directory relative file paths are resolved against
    world: WorldConfig
    robot_types: dict[str, dict[str, float]]
    seed: int | None
    #: Entities of the sections parsed before this one, by section key (read only), so a
    #: section can check itself against earlier ones (cubes must rest on tables, arms must
    #: not stand in them).
    earlier: Mapping[str, list] = field(default_factory=dict)

    def resolve(self, relative: str) -> Path:
        """Resolve a path written in the scenario file."""
        return (self.base_dir / relative).resolve()


SectionParser = Callable[[Any, SectionContext], 'list[SceneEntity]']


@dataclass(frozen=True)
class Scenario:
    name: str
    source: Path | None
    world: WorldConfig
    camera: CameraConfig
    robot_types: dict[str, dict[str, float]]
    # sections[key] = entities returned by that section's parser, in registration order
    sections: dict[str, list] = field(default_factory=dict)
    seed: int | None = None

    def entities(self) -> list:
        """Every section entity in spawn order."""
        return [entity for entities in self.sections.values() for entity in entities]


_SECTION_PARSERS: dict[str, SectionParser] = {}


def register_section(key: str, parser: SectionParser) -> None:
    """Let top-level key ``key`` be parsed by ``parser(value, context) -> [SceneEntity]``.

    Registering an existing key replaces its parser but keeps its position in the
    spawn order. Entities get labels in registration order of their sections.
    """
    if not isinstance(key, str) or not key.isidentifier():
        raise ValueError(f'section key must be an identifier (got {key!r})')
    if key in TOP_LEVEL_KEYS:
        raise ValueError(f"section key '{key}' is reserved (reserved: {', '.join(TOP_LEVEL_KEYS)})")
    if not callable(parser):
        raise ValueError(f"parser for section '{key}' is not callable")
    _SECTION_PARSERS[key] = parser


def unregister_section(key: str) -> None:
    """Forget a section (mainly for tests that register temporary kinds)."""
    _SECTION_PARSERS.pop(key, None)


def registered_sections() -> list[str]:
    """Keys of every registered section, built-ins included, in spawn order."""
    _ensure_builtin_sections()
    return list(_SECTION_PARSERS)


def _ensure_builtin_sections() -> None:
    # Imported lazily: those modules import this one to register themselves.
    for module in BUILTIN_SECTION_MODULES:
        importlib.import_module(module, __package__)


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario YAML file."""
    path = Path(path)
    data = read_yaml_file(path, 'scenario file')
    try:
        return parse_scenario(data, path.resolve().parent, source=path.resolve())
    except ScenarioError as err:
        # Keep the field path first; name the file after it.
        raise ScenarioError(f'{err} (in {path})') from err


def parse_scenario(data: dict, base_dir: Path, source: Path | None = None) -> Scenario:
    """Validate a scenario already loaded from YAML; relative paths resolve against ``base_dir``."""
    _ensure_builtin_sections()
    if not isinstance(data, Mapping):
        raise ScenarioError(f'scenario: must be a mapping (got {type_name(data)})')
    for key in data:
        if key not in TOP_LEVEL_KEYS and key not in _SECTION_PARSERS:
            raise fail(str(key), 'unknown top-level field (known fields: '
                       f"{', '.join(TOP_LEVEL_KEYS)}; known sections: {', '.join(_SECTION_PARSERS)})")
    top = Fields(data, '', allowed=list(data))  # keys were checked above
    name = top.string('name')
    seed = None if data.get('seed') is None else top.integer('seed')
    world = _parse_world(data.get('world'))
    camera = _parse_camera(data.get('camera'), world)
    robot_types = _parse_robot_types(data.get('robot_types'))

    sections: dict[str, list] = {}
    for key, parser in _SECTION_PARSERS.items():
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
    _check_unique_names(sections, world)
    return Scenario(name=name, source=source, world=world, camera=camera,
                    robot_types=robot_types, sections=sections, seed=seed)


def _parse_world(value: Any) -> WorldConfig:
    fields = Fields({} if value is None else value, 'world',
                    allowed=('frame_id', 'physics_dt', 'gravity', 'bounds', 'walls'))
    bounds = fields.vector('bounds', 4, DEFAULT_BOUNDS)
    xmin, ymin, xmax, ymax = bounds
    if not (xmin < xmax and ymin < ymax):
        raise fail('world.bounds', f'must be [xmin, ymin, xmax, ymax] with xmin < xmax and ymin < ymax '
                   f'(got {list(bounds)})')
    walls = None
    if fields.raw('walls', None) is not None:
        wall_fields = Fields(fields.raw('walls'), 'world.walls', allowed=('height', 'thickness'))
        walls = WallConfig(height=wall_fields.number('height', 0.3, gt=0.0),
                           thickness=wall_fields.number('thickness', 0.05, gt=0.0))
    return WorldConfig(
        frame_id=fields.string('frame_id', 'world'),
        physics_dt=fields.number('physics_dt', DEFAULT_PHYSICS_DT, gt=0.0, le=0.05),
        gravity=fields.number('gravity', -9.81),
        bounds=bounds,  # type: ignore[arg-type]
        walls=walls,
    )


def _parse_camera(value: Any, world: WorldConfig) -> CameraConfig:
    fields = Fields({} if value is None else value, 'camera', allowed=(
        'frame_id', 'rate', 'width', 'height', 'center', 'altitude', 'fov_deg'))
    xmin, ymin, xmax, ymax = world.bounds
    return CameraConfig(
        frame_id=fields.string('frame_id', 'top_camera'),
        rate=fields.number('rate', 10.0, gt=0.0, le=100.0),
        width=fields.integer('width', 320, ge=16, le=2048),
        height=fields.integer('height', 320, ge=16, le=2048),
        center=fields.vector('center', 2, ((xmin + xmax) / 2, (ymin + ymax) / 2)),  # type: ignore[arg-type]
        altitude=fields.number('altitude', 8.0, gt=0.0),
        fov_deg=fields.number('fov_deg', 45.0, gt=1.0, lt=170.0),
    )


def _parse_robot_types(value: Any) -> dict[str, dict[str, float]]:
    types = {name: dict(params) for name, params in BUILTIN_ROBOT_TYPES.items()}
    if value is None:
        return types
    for type_key, spec in require_mapping(value, 'robot_types').items():
        path = join_path('robot_types', str(type_key))
        check_name(type_key, path)
        fields = Fields(spec, path, allowed=ROBOT_TYPE_FIELDS)
        base = types.get(type_key)
        params = {}
        for key in ROBOT_TYPE_FIELDS:
            if base is not None and not fields.has(key):
                params[key] = base[key]
            else:
                # Every robot type field is a strictly positive quantity.
                params[key] = fields.number(key, gt=0.0)
        types[type_key] = params
    return types


def _check_unique_names(sections: dict[str, list], world: WorldConfig) -> None:
    used_by: dict[str, str] = {}
    if world.walls is not None:
        used_by[WALLS_ENTITY_NAME] = 'world.walls'
    for entities in sections.values():
        for entity in entities:
            where = entity.config_path
            if entity.name in used_by:
                raise fail(join_path(where, 'name'),
                           f"duplicate name '{entity.name}' (also used by {used_by[entity.name]})")
            used_by[entity.name] = where

"""Static obstacles: boxes, arena walls and occupancy-map images (the ``obstacles`` section).

Definitions and parsing only; :mod:`.passive_bodies` spawns them in pybullet.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from collab_tools.core.fields import Fields, join_path, require_list

from .entity import EntityDefinition
from .errors import ScenarioError
from .occupancy_map import MAX_MAP_BOXES, occupancy_to_rectangles, read_grey_image, read_nav2_map
from .sections import SectionContext
from .world import WALLS_ENTITY_NAME, WorldConfig

DEFAULT_BOX_COLOR = (0.5, 0.5, 0.5)
DEFAULT_MAP_COLOR = (0.2, 0.2, 0.2)
WALL_COLOR = (0.6, 0.6, 0.65)

__all__ = ['BoxObstacle', 'WallSet', 'load_map_boxes', 'occupancy_to_rectangles', 'parse_obstacles',
           'read_grey_image']


@dataclass(eq=False)
class BoxObstacle(EntityDefinition):
    """A static (mass 0) box standing on the ground."""

    kind = 'box_obstacle'

    name: str
    center: tuple[float, float]
    size: tuple[float, float]
    height: float
    yaw: float = 0.0
    color: tuple[float, float, float] = DEFAULT_BOX_COLOR
    config_path: str = ''

    def __post_init__(self):
        self.center = (float(self.center[0]), float(self.center[1]))
        self.size = (float(self.size[0]), float(self.size[1]))
        self.height = float(self.height)
        self.yaw = float(self.yaw)
        self.color = tuple(self.color)


@dataclass(eq=False)
class WallSet(EntityDefinition):
    """Four static walls just outside ``world.bounds``; one entity, one label."""

    kind = 'wall'

    bounds: tuple[float, float, float, float]
    wall_height: float
    thickness: float
    name: str = WALLS_ENTITY_NAME
    config_path: str = 'world.walls'

    @classmethod
    def around(cls, world: WorldConfig) -> WallSet:
        """The walls ``world.walls`` asks for."""
        if world.walls is None:
            raise ValueError('world has no walls configured')
        return cls(bounds=world.bounds, wall_height=world.walls.height, thickness=world.walls.thickness)

    def wall_boxes(self) -> list[tuple[tuple[float, float], tuple[float, float]]]:
        """(center, size) of the south, north, west and east walls; corners are closed."""
        xmin, ymin, xmax, ymax = self.bounds
        t = self.thickness
        mid_x, mid_y = (xmin + xmax) / 2.0, (ymin + ymax) / 2.0
        span_x, span_y = xmax - xmin + 2.0 * t, ymax - ymin
        return [((mid_x, ymin - t / 2.0), (span_x, t)), ((mid_x, ymax + t / 2.0), (span_x, t)),
                ((xmin - t / 2.0, mid_y), (t, span_y)), ((xmax + t / 2.0, mid_y), (t, span_y))]


def load_map_boxes(map_cfg: Any, ctx: SectionContext) -> list[BoxObstacle]:
    """Turn an occupancy image into static boxes ``map_<i>``.

    Image row 0 is the top of the map (largest y); ``origin`` is the world position
    of the image's bottom-left corner. ``ctx.path`` is the map's own path
    (``obstacles.map``), which error messages start with.
    """
    path = ctx.path
    if isinstance(map_cfg, str) or (isinstance(map_cfg, dict) and 'yaml' in map_cfg):
        return _nav2_map_boxes(map_cfg, ctx)
    fields = Fields(map_cfg, path, allowed=('image', 'resolution', 'origin', 'occupied_below',
                                            'height', 'color'), error=ScenarioError)
    grey = read_grey_image(ctx.resolve(fields.string('image')), fields.path_of('image'))
    resolution = fields.number('resolution', gt=0.0)
    origin_x, origin_y = fields.vector('origin', 2)
    threshold = fields.integer('occupied_below', 128, ge=1, le=256)
    height = fields.number('height', 0.3, gt=0.0)
    color = fields.color('color', DEFAULT_MAP_COLOR)
    rows = grey.shape[0]
    rectangles = occupancy_to_rectangles(grey < threshold, MAX_MAP_BOXES)
    _check_box_count(len(rectangles), fields.path_of('image'))
    boxes = []
    for index, (row0, col0, row1, col1) in enumerate(rectangles):
        x0, x1 = origin_x + col0 * resolution, origin_x + col1 * resolution
        y0, y1 = origin_y + (rows - row1) * resolution, origin_y + (rows - row0) * resolution
        boxes.append(BoxObstacle(f'map_{index}', ((x0 + x1) / 2, (y0 + y1) / 2), (x1 - x0, y1 - y0),
                                 height, 0.0, color, config_path=path))
    return boxes


def _nav2_map_boxes(map_cfg: Any, ctx: SectionContext) -> list[BoxObstacle]:
    """``obstacles.map`` naming a Nav2 map YAML (``map: file.yaml`` or ``map: {yaml: file.yaml, height,
    color}``, relative to the scenario): its occupied and unknown cells become boxes ``map_<i>``,
    placed and rotated by the YAML's origin [x, y, yaw] (core.occupancy_map.read_nav2_map)."""
    path = ctx.path
    if isinstance(map_cfg, str):
        map_cfg = {'yaml': map_cfg}
    fields = Fields(map_cfg, path, allowed=('yaml', 'height', 'color'), error=ScenarioError)
    yaml_path = ctx.resolve(fields.string('yaml'))
    if not yaml_path.is_file():
        raise fields.fail('yaml', f"map file '{yaml_path}' does not exist")
    height = fields.number('height', 0.3, gt=0.0)
    color = fields.color('color', DEFAULT_MAP_COLOR)
    nav2 = read_nav2_map(yaml_path, error=ScenarioError, extra_fields=('name', 'description', 'border_is_obstacle'))
    boxes = nav2.boxes(limit=MAX_MAP_BOXES)
    _check_box_count(len(boxes), fields.path_of('yaml'))
    return [BoxObstacle(f'map_{index}', centre, size, height, yaw, color, config_path=path)
            for index, (centre, size, yaw) in enumerate(boxes)]


def _check_box_count(count: int, field_path: str) -> None:
    if count > MAX_MAP_BOXES:
        raise ScenarioError(f'{field_path}: the map needs more than {MAX_MAP_BOXES} boxes to cover its occupied '
                            'pixels (the most the simulator steps in real time: README "Input files"); use a '
                            'coarser or simpler map')


def parse_obstacles(value: Any, context: SectionContext) -> list[BoxObstacle]:
    """Parse the ``obstacles`` section: ``boxes`` list and optional ``map`` image."""
    if value is None:
        return []
    section = Fields(value, context.path, allowed=('boxes', 'map'), error=ScenarioError)
    obstacles: list[BoxObstacle] = []
    boxes_path = section.path_of('boxes')
    for index, item in enumerate(require_list(section.raw('boxes', []) or [], boxes_path, error=ScenarioError)):
        path = join_path(boxes_path, index)
        fields = Fields(item, path, allowed=('name', 'center', 'size', 'height', 'yaw', 'color'), error=ScenarioError)
        obstacles.append(BoxObstacle(
            name=fields.name('name', f'obstacle_{index}'),
            center=fields.vector('center', 2),  # type: ignore[arg-type]
            size=fields.vector('size', 2, gt=0.0),  # type: ignore[arg-type]
            height=fields.number('height', 0.3, gt=0.0),
            yaw=fields.number('yaw', 0.0),
            color=fields.color('color', DEFAULT_BOX_COLOR),
            config_path=path))
    if section.raw('map', None) is not None:
        map_context = SectionContext(path=section.path_of('map'), base_dir=context.base_dir,
                                     world=context.world, robot_types=context.robot_types,
                                     seed=context.seed)
        obstacles.extend(load_map_boxes(section.raw('map'), map_context))
    return obstacles

"""Static obstacles: boxes, arena walls and occupancy-map images (the ``obstacles`` section)."""
from __future__ import annotations

from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pybullet as p

from .fields import Fields, fail, join_path, require_list
from .scenario import WALLS_ENTITY_NAME, SectionContext, WorldConfig, register_section
from .scene import SceneEntity

DEFAULT_BOX_COLOR = (0.5, 0.5, 0.5)
DEFAULT_MAP_COLOR = (0.2, 0.2, 0.2)
WALL_COLOR = (0.6, 0.6, 0.65)


def _spawn_static_box(client: int, center_xy: tuple[float, float], size_xy: tuple[float, float],
                      height: float, yaw: float, color: tuple[float, float, float]) -> int:
    half_extents = [size_xy[0] / 2.0, size_xy[1] / 2.0, height / 2.0]
    collision = p.createCollisionShape(p.GEOM_BOX, halfExtents=half_extents, physicsClientId=client)
    visual = p.createVisualShape(p.GEOM_BOX, halfExtents=half_extents, rgbaColor=[*color, 1.0],
                                 physicsClientId=client)
    return p.createMultiBody(
        baseMass=0.0, baseCollisionShapeIndex=collision, baseVisualShapeIndex=visual,
        basePosition=[center_xy[0], center_xy[1], height / 2.0],
        baseOrientation=p.getQuaternionFromEuler([0.0, 0.0, yaw]), physicsClientId=client)


class BoxObstacle(SceneEntity):
    """A static (mass 0) box standing on the ground."""

    kind = 'box_obstacle'

    def __init__(self, name: str, center: tuple[float, float], size: tuple[float, float],
                 height: float, yaw: float = 0.0, color: tuple[float, float, float] = DEFAULT_BOX_COLOR,
                 config_path: str = ''):
        self.name = name
        self.center = (float(center[0]), float(center[1]))
        self.size = (float(size[0]), float(size[1]))
        self.height = float(height)
        self.yaw = float(yaw)
        self.color = tuple(color)
        self.config_path = config_path

    def spawn(self, client: int) -> list[int]:
        return [_spawn_static_box(client, self.center, self.size, self.height, self.yaw, self.color)]


class WallSet(SceneEntity):
    """Four static walls just outside ``world.bounds``; one entity, one label."""

    kind = 'wall'

    def __init__(self, world: WorldConfig):
        if world.walls is None:
            raise ValueError('world has no walls configured')
        self.name = WALLS_ENTITY_NAME
        self.config_path = 'world.walls'
        self.bounds = world.bounds
        self.wall_height = world.walls.height
        self.thickness = world.walls.thickness

    def wall_boxes(self) -> list[tuple[tuple[float, float], tuple[float, float]]]:
        """(center, size) of the south, north, west and east walls; corners are closed."""
        xmin, ymin, xmax, ymax = self.bounds
        t = self.thickness
        mid_x, mid_y = (xmin + xmax) / 2.0, (ymin + ymax) / 2.0
        span_x, span_y = xmax - xmin + 2.0 * t, ymax - ymin
        return [((mid_x, ymin - t / 2.0), (span_x, t)), ((mid_x, ymax + t / 2.0), (span_x, t)),
                ((xmin - t / 2.0, mid_y), (t, span_y)), ((xmax + t / 2.0, mid_y), (t, span_y))]

    def spawn(self, client: int) -> list[int]:
        return [_spawn_static_box(client, center, size, self.wall_height, 0.0, WALL_COLOR)
                for center, size in self.wall_boxes()]


def occupancy_to_rectangles(occupied: np.ndarray) -> list[tuple[int, int, int, int]]:
    """Cover a boolean grid with non-overlapping rectangles (row0, col0, row1, col1), ends exclusive.

    Each row is split into maximal runs of occupied cells; a run continues the
    rectangle above it when it spans exactly the same columns. The union of the
    rectangles equals ``occupied`` exactly.
    """
    grid = np.asarray(occupied)
    if grid.ndim != 2:
        raise ValueError(f'occupancy grid must be 2-D (got shape {grid.shape})')
    grid = grid.astype(bool)
    rectangles: list[tuple[int, int, int, int]] = []
    open_since: dict[tuple[int, int], int] = {}  # (col0, col1) -> first row of the open rectangle
    for row in range(grid.shape[0] + 1):
        runs: set[tuple[int, int]] = set()
        if row < grid.shape[0]:
            # Run boundaries are where the padded row changes value.
            padded = np.concatenate(([False], grid[row], [False])).astype(np.int8)
            edges = np.flatnonzero(np.diff(padded))
            runs = {(int(start), int(stop)) for start, stop in zip(edges[::2], edges[1::2])}
        for span in sorted(set(open_since) - runs):
            rectangles.append((open_since.pop(span), span[0], row, span[1]))
        for span in runs - set(open_since):
            open_since[span] = row
    return sorted(rectangles)


def read_grey_image(image_path: Path, field_path: str) -> np.ndarray:
    """The occupancy image a map field names, as 8-bit grey; errors start with ``field_path``."""
    if not image_path.is_file():
        raise fail(field_path, f"image file '{image_path}' does not exist")
    grey = cv2.imread(str(image_path), cv2.IMREAD_GRAYSCALE)
    if grey is None:
        raise fail(field_path, f"cannot read '{image_path}' as an image")
    return grey


def load_map_boxes(map_cfg: Any, ctx: SectionContext) -> list[BoxObstacle]:
    """Turn an occupancy image into static boxes ``map_<i>``.

    Image row 0 is the top of the map (largest y); ``origin`` is the world position
    of the image's bottom-left corner. ``ctx.path`` is the map's own path
    (``obstacles.map``), which error messages start with.
    """
    path = ctx.path
    fields = Fields(map_cfg, path, allowed=('image', 'resolution', 'origin', 'occupied_below',
                                            'height', 'color'))
    grey = read_grey_image(ctx.resolve(fields.string('image')), fields.path_of('image'))
    resolution = fields.number('resolution', gt=0.0)
    origin_x, origin_y = fields.vector('origin', 2)
    threshold = fields.integer('occupied_below', 128, ge=1, le=256)
    height = fields.number('height', 0.3, gt=0.0)
    color = fields.color('color', DEFAULT_MAP_COLOR)
    rows = grey.shape[0]
    boxes = []
    for index, (row0, col0, row1, col1) in enumerate(occupancy_to_rectangles(grey < threshold)):
        x0, x1 = origin_x + col0 * resolution, origin_x + col1 * resolution
        y0, y1 = origin_y + (rows - row1) * resolution, origin_y + (rows - row0) * resolution
        boxes.append(BoxObstacle(f'map_{index}', ((x0 + x1) / 2, (y0 + y1) / 2), (x1 - x0, y1 - y0),
                                 height, 0.0, color, config_path=path))
    return boxes


def parse_obstacles(value: Any, context: SectionContext) -> list[BoxObstacle]:
    """Parse the ``obstacles`` section: ``boxes`` list and optional ``map`` image."""
    if value is None:
        return []
    section = Fields(value, context.path, allowed=('boxes', 'map'))
    obstacles: list[BoxObstacle] = []
    boxes_path = section.path_of('boxes')
    for index, item in enumerate(require_list(section.raw('boxes', []) or [], boxes_path)):
        path = join_path(boxes_path, index)
        fields = Fields(item, path, allowed=('name', 'center', 'size', 'height', 'yaw', 'color'))
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


register_section('obstacles', parse_obstacles)

"""Tables divided into cells and the cubes on them (the ``tables`` and ``cubes`` sections).

A table is a static block whose top surface is at ``height``; an optional grid draws
thin, visual-only lines on its top so the top-view camera shows the cells (the lines
have no collision shape, so cubes rest on the table top itself). Cells are numbered
like image pixels: row 0 is the row with the largest y (top of the camera image),
column 0 the one with the smallest x.

A cube is a dynamic box. Its scenario entry gives only x, y: it stands on the table
whose top contains its whole footprint, or on the ground when it touches no table.
A cube straddling a table edge, overlapping another cube or an obstacle is an error.

Definitions and parsing only; :mod:`.passive_bodies` spawns them in pybullet.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Iterable

from collab_tools.core.fields import Fields, fail, join_path, require_list

from .entity import EntityDefinition
from .errors import ScenarioError
from .obstacles import BoxObstacle
from .sections import SectionContext

DEFAULT_TABLE_COLOR = (0.78, 0.66, 0.5)
DEFAULT_GRID_COLOR = (0.15, 0.15, 0.15)
DEFAULT_GRID_LINE_WIDTH = 0.004   # m: 2-3 pixels with the test_tabletop camera
DEFAULT_CUBE_EDGE = 0.03          # m: four fit in a 0.10 m cell with 0.01 m clearance
DEFAULT_CUBE_MASS = 0.05          # kg


Rect = tuple[float, float, float, float]  # xmin ymin xmax ymax


@dataclass(frozen=True)
class GridSpec:
    rows: int
    cols: int
    line_width: float
    color: tuple[float, float, float]


def square_footprint(x: float, y: float, edge: float, yaw: float) -> Rect:
    """Axis-aligned bounding rectangle of a square of side ``edge`` turned by ``yaw``."""
    half = edge / 2.0 * (abs(math.cos(yaw)) + abs(math.sin(yaw)))
    return (x - half, y - half, x + half, y + half)


def rect_inside(inner: Rect, outer: Rect, tolerance: float = 1e-9) -> bool:
    return (inner[0] >= outer[0] - tolerance and inner[1] >= outer[1] - tolerance
            and inner[2] <= outer[2] + tolerance and inner[3] <= outer[3] + tolerance)


def rects_overlap(a: Rect, b: Rect) -> bool:
    """True if the open interiors intersect (touching edges do not count)."""
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def box_obstacle_rect(box: BoxObstacle) -> Rect:
    """Bounding rectangle of a (possibly turned) box obstacle."""
    c, s = abs(math.cos(box.yaw)), abs(math.sin(box.yaw))
    half_x = (box.size[0] * c + box.size[1] * s) / 2.0
    half_y = (box.size[0] * s + box.size[1] * c) / 2.0
    return (box.center[0] - half_x, box.center[1] - half_y, box.center[0] + half_x, box.center[1] + half_y)


@dataclass(eq=False)
class Table(EntityDefinition):
    """A static table block; its top is at ``height``."""

    kind = 'table'

    name: str
    center: tuple[float, float]
    size: tuple[float, float]
    height: float
    color: tuple[float, float, float] = DEFAULT_TABLE_COLOR
    grid: GridSpec | None = None
    config_path: str = ''

    def __post_init__(self):
        self.center = (float(self.center[0]), float(self.center[1]))
        self.size = (float(self.size[0]), float(self.size[1]))
        self.height = float(self.height)
        self.color = tuple(self.color)

    # -- geometry ---------------------------------------------------------------

    @property
    def top_rect(self) -> Rect:
        """(xmin, ymin, xmax, ymax) of the top surface."""
        half_x, half_y = self.size[0] / 2.0, self.size[1] / 2.0
        return (self.center[0] - half_x, self.center[1] - half_y,
                self.center[0] + half_x, self.center[1] + half_y)

    def contains(self, x: float, y: float) -> bool:
        """True if (x, y) lies on the table top (edges included)."""
        return rect_inside((x, y, x, y), self.top_rect)

    @property
    def cell_size(self) -> tuple[float, float]:
        """(width along x, depth along y) of one cell; the whole top is one cell without a grid."""
        rows, cols = (self.grid.rows, self.grid.cols) if self.grid else (1, 1)
        return self.size[0] / cols, self.size[1] / rows

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, cols) of the grid."""
        return (self.grid.rows, self.grid.cols) if self.grid else (1, 1)

    def cell_region(self, row: int, col: int) -> Rect:
        """(xmin, ymin, xmax, ymax) of cell (row, col); row 0 has the largest y."""
        rows, cols = self.shape
        if not (0 <= row < rows and 0 <= col < cols):
            raise IndexError(f"table '{self.name}' has {rows}x{cols} cells (got row {row}, col {col})")
        width, depth = self.cell_size
        xmin, _, _, ymax = self.top_rect
        return (xmin + col * width, ymax - (row + 1) * depth, xmin + (col + 1) * width, ymax - row * depth)

    def cell_at(self, x: float, y: float) -> tuple[int, int] | None:
        """(row, col) of the cell containing (x, y), or None off the table."""
        if not self.contains(x, y):
            return None
        rows, cols = self.shape
        width, depth = self.cell_size
        xmin, _, _, ymax = self.top_rect
        col = min(cols - 1, int((x - xmin) / width))
        row = min(rows - 1, int((ymax - y) / depth))
        return row, col

    def grid_lines(self) -> list[tuple[tuple[float, float], tuple[float, float]]]:
        """(center xy, size xy) of every grid line, the outer border included."""
        if self.grid is None:
            return []
        xmin, ymin, xmax, ymax = self.top_rect
        width, depth = self.cell_size
        w = self.grid.line_width
        lines = []
        # Border lines sit just inside the edge so they never overhang the table.
        for col in range(self.grid.cols + 1):
            x = min(max(xmin + col * width, xmin + w / 2.0), xmax - w / 2.0)
            lines.append(((x, self.center[1]), (w, self.size[1])))
        for row in range(self.grid.rows + 1):
            y = min(max(ymin + row * depth, ymin + w / 2.0), ymax - w / 2.0)
            lines.append(((self.center[0], y), (self.size[0], w)))
        return lines

@dataclass(eq=False)
class Cube(EntityDefinition):
    """A dynamic cube resting on a table (``support`` = its name) or on the ground (None)."""

    kind = 'cube'

    name: str
    position: tuple[float, float]
    edge: float
    mass: float
    color: tuple[float, float, float]
    yaw: float = 0.0
    support: str | None = None
    support_height: float = 0.0
    config_path: str = ''

    def __post_init__(self):
        self.position = (float(self.position[0]), float(self.position[1]))
        self.edge = float(self.edge)
        self.mass = float(self.mass)
        self.color = tuple(self.color)
        self.yaw = float(self.yaw)
        self.support_height = float(self.support_height)

    @property
    def initial_z(self) -> float:
        """Height of the cube's centre when it rests on its support."""
        return self.support_height + self.edge / 2.0

    def footprint(self) -> Rect:
        return square_footprint(*self.position, self.edge, self.yaw)

def tables_in(earlier: dict[str, list] | Any) -> list[Table]:
    return [entity for entity in earlier.get('tables', []) if isinstance(entity, Table)]


def support_under(tables: Iterable[Table], footprint: Rect) -> tuple[Table | None, Table | None]:
    """(table whose top holds the whole footprint, table the footprint only partly overlaps)."""
    holding = partial = None
    for table in tables:
        if rect_inside(footprint, table.top_rect):
            holding = table
        elif rects_overlap(footprint, table.top_rect) and partial is None:
            partial = table
    return holding, partial


def parse_tables(value: Any, context: SectionContext) -> list[Table]:
    """Parse the ``tables`` section: a list of table entries."""
    if value is None:
        return []
    tables: list[Table] = []
    for index, item in enumerate(require_list(value, context.path, error=ScenarioError)):
        path = join_path(context.path, index)
        fields = Fields(item, path, allowed=('name', 'center', 'size', 'height', 'color', 'grid'), error=ScenarioError)
        grid = None
        if fields.raw('grid', None) is not None:
            grid_fields = Fields(fields.raw('grid'), fields.path_of('grid'),
                                 allowed=('rows', 'cols', 'line_width', 'color'), error=ScenarioError)
            grid = GridSpec(rows=grid_fields.integer('rows', ge=1, le=100),
                            cols=grid_fields.integer('cols', ge=1, le=100),
                            line_width=grid_fields.number('line_width', DEFAULT_GRID_LINE_WIDTH, gt=0.0),
                            color=grid_fields.color('color', DEFAULT_GRID_COLOR))
        table = Table(name=fields.name('name'),
                      center=fields.vector('center', 2),  # type: ignore[arg-type]
                      size=fields.vector('size', 2, gt=0.0),  # type: ignore[arg-type]
                      height=fields.number('height', gt=0.0, le=5.0),
                      color=fields.color('color', DEFAULT_TABLE_COLOR),
                      grid=grid, config_path=path)
        if grid is not None:
            smallest_cell = min(table.cell_size)
            if grid.line_width >= smallest_cell / 2.0:
                raise fail(join_path(fields.path_of('grid'), 'line_width'),
                           f'must be < half a cell ({smallest_cell / 2.0:.4f} m) (got {grid.line_width})', error=ScenarioError)
        xmin, ymin, xmax, ymax = table.top_rect
        if not (context.world.contains(xmin, ymin) and context.world.contains(xmax, ymax)):
            raise fail(path, f'table top [{xmin:.3f}, {ymin:.3f}, {xmax:.3f}, {ymax:.3f}] must lie inside '
                       f'world.bounds {list(context.world.bounds)}', error=ScenarioError)
        for other in tables:
            if rects_overlap(table.top_rect, other.top_rect):
                raise fail(path, f"table '{table.name}' overlaps table '{other.name}' ({other.config_path})", error=ScenarioError)
        tables.append(table)
    return tables


def parse_cubes(value: Any, context: SectionContext) -> list[Cube]:
    """Parse the ``cubes`` section; each cube's height comes from the table below it."""
    if value is None:
        return []
    tables = tables_in(context.earlier)
    obstacles = [box for box in context.earlier.get('obstacles', []) if isinstance(box, BoxObstacle)]
    cubes: list[Cube] = []
    for index, item in enumerate(require_list(value, context.path, error=ScenarioError)):
        path = join_path(context.path, index)
        fields = Fields(item, path, allowed=('name', 'position', 'size', 'mass', 'color', 'yaw'), error=ScenarioError)
        name = fields.name('name')
        position = fields.vector('position', 2)
        edge = fields.number('size', DEFAULT_CUBE_EDGE, gt=0.0, le=0.5)
        mass = fields.number('mass', DEFAULT_CUBE_MASS, gt=0.0, le=100.0)
        color = fields.color('color')
        yaw = fields.number('yaw', 0.0)
        footprint = square_footprint(position[0], position[1], edge, yaw)
        where = f'cube footprint [{", ".join(f"{v:.3f}" for v in footprint)}]'
        holding, partial = support_under(tables, footprint)
        if holding is None and partial is not None:
            raise fail(fields.path_of('position'), f"{where} straddles the edge of table '{partial.name}' "
                       f'(top {[round(v, 4) for v in partial.top_rect]}); put it wholly on or off the table', error=ScenarioError)
        if holding is None and not (context.world.contains(footprint[0], footprint[1])
                                    and context.world.contains(footprint[2], footprint[3])):
            raise fail(fields.path_of('position'), f'{where} is on no table and not inside world.bounds '
                       f'{list(context.world.bounds)}', error=ScenarioError)
        for box in obstacles:
            if rects_overlap(footprint, box_obstacle_rect(box)) and (holding is None
                                                                      or box.height > holding.height):
                raise fail(fields.path_of('position'), f"{where} overlaps obstacle '{box.name}'", error=ScenarioError)
        support = holding.name if holding else None
        for other in cubes:
            if other.support == support and rects_overlap(footprint, other.footprint()):
                raise fail(fields.path_of('position'),
                           f"{where} overlaps cube '{other.name}' ({other.config_path})", error=ScenarioError)
        cubes.append(Cube(name, position, edge, mass, color, yaw,  # type: ignore[arg-type]
                          support=support,
                          support_height=holding.height if holding else 0.0, config_path=path))
    return cubes


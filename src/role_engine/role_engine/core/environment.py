"""The environment ``e`` and its per-robot-type views ``Env_tau`` (Algorithm 2, lines 2-4).

An :class:`Environment` is a y-up occupancy grid (see :mod:`.grid`) read from a map file,
an occupancy image or the top-view camera (:mod:`.top_view`). :meth:`Environment.for_robot`
builds the view of one robot type: obstacles inflated by the robot radius, the cells its
centre may visit, and the configuration-space SDF (Appendix A step 1, Sec. IV-B).

Map file: a Nav2 map YAML (nav2_map_server's format, read by
``pybullet_bridge.core.occupancy_map.read_nav2_map``; the bridge scenario's ``obstacles.map`` reads
the same file, so one map serves both the simulation and the planner)::

    image: env_1.png            # required, path relative to the YAML file; with negate 0 white is free
    resolution: 0.025           # required, m per pixel, > 0
    origin: [-2.5, -2.5, 0.0]   # required, [x, y, yaw] of the image's bottom-left corner (yaw rad)
    negate: 0                   # required, 0 / 1
    occupied_thresh: 0.65       # required, [0, 1]: occupied when (255 - shade) / 255 > this
    free_thresh: 0.25           # required, [0, 1]: free below; in between unknown = an obstacle
    mode: trinary               # optional (trinary only)
    border_is_obstacle: true    # optional, ours: the area beyond the image is a wall (default true)
    name: env_1                 # optional, ours: default the YAML file's stem
    description: ''             # optional free text

A rotated map (yaw != 0) is resampled onto an axis-aligned grid of the same resolution covering
it (cells outside the image unknown, i.e. occupied). The earlier form -- ``origin: [x, y]`` and
``occupied_below: 128`` (grey value below which a pixel is occupied), no ``negate`` /
``*_thresh`` / ``mode`` -- is still read.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy import ndimage

from collab_tools.core.fields import Fields, fail, read_yaml_file
from collab_tools.core.settings import echo
from pybullet_bridge.core.occupancy_map import Nav2Map, nav2_map_from_data, read_grey_image
# (one reader for the simulation's and the planner's maps)

from .errors import RoleEngineError
from .grid import GridFrame, image_rows_to_grid
from .sdf import SignedDistanceField

MAP_FILE_FIELDS = ('image', 'resolution', 'origin', 'occupied_below', 'border_is_obstacle',
                   'name', 'description')
#: Keys of a role-engine map beyond Nav2's.
MAP_EXTRA_FIELDS = ('border_is_obstacle', 'name', 'description')
#: Any of these says the file is a Nav2 map YAML (else the earlier occupied_below form).
NAV2_MARKERS = ('negate', 'occupied_thresh', 'free_thresh', 'mode')
#: 8-connectivity: a robot centre moves between diagonal neighbours too.
EIGHT_CONNECTED = np.ones((3, 3), dtype=bool)


class Environment:
    """Static obstacles of the arena on a grid (``occupied[iy, ix]``, True = obstacle)."""

    def __init__(self, occupied: np.ndarray, resolution: float, origin: tuple[float, float], *,
                 border_is_obstacle: bool = True, name: str = 'environment'):
        grid = np.asarray(occupied)
        if grid.ndim != 2 or grid.size == 0:
            raise RoleEngineError(f'{name}.occupied: must be a non-empty 2-D array (got shape {grid.shape})')
        if grid.dtype != bool:
            raise RoleEngineError(f'{name}.occupied: must be a boolean array (got dtype {grid.dtype})')
        self.name = name
        self.occupied = grid.copy()
        self.occupied.setflags(write=False)
        self.frame = GridFrame(float(resolution), tuple(origin), grid.shape)
        self.border_is_obstacle = bool(border_is_obstacle)
        # Workspace SDF: distance from each point to the nearest (uninflated) obstacle surface.
        self.sdf = SignedDistanceField.from_occupancy(grid, self.frame.resolution, self.frame.origin,
                                                      border_is_obstacle=self.border_is_obstacle)

    @property
    def resolution(self) -> float:
        return self.frame.resolution

    @property
    def origin(self) -> tuple[float, float]:
        return self.frame.origin

    @property
    def shape(self) -> tuple[int, int]:
        return self.frame.shape

    @classmethod
    def from_image(cls, grey: np.ndarray, resolution: float, origin: tuple[float, float], *,
                   occupied_below: int = 128, border_is_obstacle: bool = True,
                   name: str = 'environment') -> Environment:
        """Environment of a greyscale occupancy image (row 0 = top = largest y)."""
        grey = np.asarray(grey)
        if grey.ndim != 2 or grey.size == 0:
            raise RoleEngineError(f'{name}.image: must be a non-empty greyscale image (got shape {grey.shape})')
        return cls(image_rows_to_grid(grey < occupied_below), resolution, origin,
                   border_is_obstacle=border_is_obstacle, name=name)

    def for_robot(self, robot_type: RobotType) -> RobotEnvironment:
        """The view of this environment for one robot type (``Env_tau``)."""
        return RobotEnvironment(self, robot_type)

    def image(self) -> np.ndarray:
        """The occupancy as a uint8 image (row 0 at the top): 0 occupied, 255 free."""
        return np.where(np.flipud(self.occupied), 0, 255).astype(np.uint8)


@dataclass(frozen=True)
class RobotType:
    """What the environment view and the controller need to know about one kind of robot.

    ``inflation_margin`` widens the inflation beyond the radius (a safety distance for
    tracking errors); velocities (m/s, rad/s) are the platform limits, None = unlimited.
    """

    name: str
    radius: float
    inflation_margin: float = 0.0
    max_linear_velocity: float | None = None
    max_angular_velocity: float | None = None

    def __post_init__(self) -> None:
        for key in ('radius', 'inflation_margin'):
            value = getattr(self, key)
            if not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0:
                raise RoleEngineError(f'robot_type {self.name!r}.{key}: must be a finite number >= 0 (got {echo(value)})')
        for key in ('max_linear_velocity', 'max_angular_velocity'):
            value = getattr(self, key)
            if value is not None and (not isinstance(value, (int, float)) or not math.isfinite(value)
                                      or value <= 0):
                raise RoleEngineError(f'robot_type {self.name!r}.{key}: must be a finite number > 0 or None '
                                      f'(got {echo(value)})')

    @property
    def inflation(self) -> float:
        return self.radius + self.inflation_margin


@dataclass
class RobotEnvironment:
    """``Env_tau`` and ``Sdf_tau``: the environment as seen by the centre of one robot type.

    ``inflated`` marks every cell whose centre is closer than the robot's inflation
    radius to an obstacle surface; ``visitable`` is its complement (Fig. 16B). ``sdf`` is
    the signed distance to the inflated obstacles, i.e. the clearance of the robot's
    body (positive = the whole disc is free), which the GP obstacle factor uses directly.
    ``components`` labels the 8-connected visitable regions (0 = not visitable).
    """

    environment: Environment
    robot_type: RobotType
    inflated: np.ndarray = field(init=False)
    visitable: np.ndarray = field(init=False)
    sdf: SignedDistanceField = field(init=False)
    components: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        env = self.environment
        self.inflated = env.sdf.data < self.robot_type.inflation
        self.visitable = ~self.inflated
        self.sdf = SignedDistanceField.from_occupancy(self.inflated, env.resolution, env.origin,
                                                      border_is_obstacle=env.border_is_obstacle)
        self.components, _ = ndimage.label(self.visitable, structure=EIGHT_CONNECTED)
        for array in (self.inflated, self.visitable, self.components):
            array.setflags(write=False)

    @property
    def frame(self) -> GridFrame:
        return self.environment.frame

    def cell_of(self, point: tuple[float, float]) -> tuple[int, int]:
        """(iy, ix) of the cell containing a world point (may be off the grid)."""
        iy, ix = self.frame.world_to_cell(np.asarray(point, dtype=float))[0]
        return int(iy), int(ix)

    def is_visitable(self, point: tuple[float, float]) -> bool:
        """Whether the robot's centre may stand at this world point."""
        cell = np.array([self.cell_of(point)])
        return bool(self.frame.contains_cells(cell)[0] and self.visitable[tuple(cell[0])])


#: Most cells of a grid built over world.bounds (a formation task's grid_resolution): 1000 x 1000
#: cells took 0.7 s to rasterise plus 0.2 s per robot type's SDF (load 8); 1e-9 m cells cannot fit.
MAX_GRID_CELLS = 1_000_000


def environment_from_scenario(scenario, resolution: float) -> Environment:
    """The bridge scenario's static boxes rasterised on a grid over ``world.bounds`` (walls = the border).

    A cell is occupied when its centre lies inside a box (yaw respected). What the top-view
    camera would segment, without its pixel errors.
    """
    xmin, ymin, xmax, ymax = scenario.world.bounds
    if (xmax - xmin) * (ymax - ymin) / resolution ** 2 > MAX_GRID_CELLS:
        raise RoleEngineError(f'grid_resolution: {resolution:g} m gives more than {MAX_GRID_CELLS} cells over '
                              f'world.bounds of {scenario.name}')
    frame = GridFrame.covering(scenario.world.bounds, resolution)
    iy, ix = np.mgrid[0:frame.shape[0], 0:frame.shape[1]]
    centres = frame.cell_to_world(np.column_stack([iy.ravel(), ix.ravel()]))
    occupied = np.zeros(len(centres), dtype=bool)
    for box in scenario.sections.get('obstacles', []):
        c, s = math.cos(box.yaw), math.sin(box.yaw)
        d = centres - np.asarray(box.center)
        along, across = d[:, 0] * c + d[:, 1] * s, -d[:, 0] * s + d[:, 1] * c
        occupied |= (np.abs(along) <= box.size[0] / 2.0) & (np.abs(across) <= box.size[1] / 2.0)
    return Environment(occupied.reshape(frame.shape), resolution, frame.origin, border_is_obstacle=True,
                       name=scenario.name)


def load_map_file(path: str | Path) -> Environment:
    """Read a map YAML (format in the module docstring: Nav2's, or the earlier occupied_below form)."""
    path = Path(path)
    where = str(path)
    data = read_yaml_file(path, 'map file', RoleEngineError)
    if isinstance(data, dict) and any(key in data for key in NAV2_MARKERS):
        return environment_from_nav2(nav2_map_from_data(data, path, where, error=RoleEngineError,
                                                        extra_fields=MAP_EXTRA_FIELDS), where)
    fields = Fields(data, where, allowed=MAP_FILE_FIELDS, error=RoleEngineError)
    grey = read_grey_image(path.parent / fields.string('image'), fields.path_of('image'), RoleEngineError)
    _check_map_cells(grey.size, fields.path_of('image'))
    resolution = fields.number('resolution', gt=0.0)
    origin = fields.vector('origin', 2)
    threshold = fields.integer('occupied_below', 128, ge=1, le=256)
    border = fields.raw('border_is_obstacle', True)
    if not isinstance(border, bool):
        raise fail(fields.path_of('border_is_obstacle'), f'must be true or false (got {echo(border)})',
                   RoleEngineError)
    name = fields.string('name', path.stem)
    fields.raw('description', '')
    return Environment.from_image(grey, resolution, origin, occupied_below=threshold,
                                  border_is_obstacle=border, name=name)


def environment_from_nav2(nav2: Nav2Map, where: str = '') -> Environment:
    """The environment of a read Nav2 map: occupied and unknown cells are obstacles (module docstring)."""
    where = where or str(nav2.source)
    border = nav2.extra.get('border_is_obstacle', True)
    if not isinstance(border, bool):
        raise fail(f'{where}.border_is_obstacle', f'must be true or false (got {echo(border)})', RoleEngineError)
    name = nav2.extra.get('name', nav2.source.stem)
    if not isinstance(name, str) or not name:
        raise fail(f'{where}.name', f'must be a non-empty string (got {echo(name)})', RoleEngineError)
    _check_map_cells(nav2.cells.size, f'{where}.image')
    occupied, origin = nav2.axis_aligned(unknown_is_occupied=True)
    return Environment(occupied, nav2.resolution, origin, border_is_obstacle=border, name=name)


def _check_map_cells(cells: int, field_path: str) -> None:
    if cells > MAX_GRID_CELLS:
        raise fail(field_path, f'the image has {cells} pixels; a planning map has at most {MAX_GRID_CELLS} cells '
                   '(what the engine builds in about a second)', RoleEngineError)

"""An :class:`~.environment.Environment` as the cells of a ``nav_msgs/OccupancyGrid`` and back.

Nav2's map conventions: ``data`` is row-major starting at cell (0, 0), whose bottom-left corner
is ``info.origin`` (x grows along a row, y from row to row), so it is the role engine's y-up
``occupied[iy, ix]`` grid flattened as it is. Cells are 100 (occupied) or 0 (free); when read,
a cell is occupied from ``occupied_from`` (Nav2's trinary threshold, 65 %) and an unknown cell
(-1) is occupied too, as unknown space is not free. Only an unrotated origin is accepted (the
role engine's grids are axis-aligned). An OccupancyGrid says nothing about beyond its border:
the role engine's maps treat it as a wall (robots stay on the map), so the reader does too.

Pure numpy: the node layer (role_messages) copies these fields to and from the message.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .environment import Environment
from .errors import RoleEngineError

OCCUPIED, FREE, UNKNOWN = 100, 0, -1
#: Occupancy (percent) from which a cell is an obstacle when read (Nav2 map_server's default 0.65).
OCCUPIED_FROM = 65


@dataclass(frozen=True)
class OccupancyCells:
    """The fields of an OccupancyGrid's ``info`` and ``data`` that place and fill the cells."""

    width: int
    height: int
    resolution: float
    origin: tuple[float, float]       # world x, y of the bottom-left corner of cell (0, 0)
    data: np.ndarray                  # (height * width,) int8, row-major from cell (0, 0)


def occupancy_cells(environment: Environment) -> OccupancyCells:
    """The environment as OccupancyGrid cells (100 occupied, 0 free)."""
    ny, nx = environment.shape
    data = np.where(environment.occupied, OCCUPIED, FREE).astype(np.int8).ravel()
    return OccupancyCells(nx, ny, environment.resolution, environment.origin, data)


def quaternion_yaw(x: float, y: float, z: float, w: float) -> float:
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def environment_from_cells(cells: OccupancyCells, *, origin_yaw: float = 0.0, occupied_from: int = OCCUPIED_FROM,
                           name: str = 'map') -> Environment:
    """The environment of OccupancyGrid cells (module docstring); RoleEngineError naming the field."""
    width, height = int(cells.width), int(cells.height)
    if width < 1 or height < 1:
        raise RoleEngineError(f'{name}.info: width and height must be >= 1 (got {width} x {height})')
    resolution = float(cells.resolution)
    if not (math.isfinite(resolution) and resolution > 0.0):
        raise RoleEngineError(f'{name}.info.resolution: must be a finite number > 0 (got {resolution})')
    if not all(math.isfinite(float(v)) for v in cells.origin):
        raise RoleEngineError(f'{name}.info.origin.position: must be finite (got {tuple(cells.origin)})')
    if not (math.isfinite(origin_yaw) and abs(math.remainder(origin_yaw, 2.0 * math.pi)) < 1e-6):
        raise RoleEngineError(f'{name}.info.origin.orientation: the map must not be rotated (yaw {origin_yaw:.4g} rad)')
    data = np.asarray(cells.data).ravel()
    if data.size != width * height:
        raise RoleEngineError(f'{name}.data: must have width x height = {width * height} cells (got {data.size})')
    values = data.astype(np.int16)
    if values.size and (values.min() < UNKNOWN or values.max() > OCCUPIED):
        raise RoleEngineError(f'{name}.data: cells must be -1 (unknown) or 0..100 '
                              f'(got {int(values.min())}..{int(values.max())})')
    occupied = (values == UNKNOWN) | (values >= occupied_from)
    return Environment(occupied.reshape(height, width), resolution, (float(cells.origin[0]), float(cells.origin[1])),
                       border_is_obstacle=True, name=name)

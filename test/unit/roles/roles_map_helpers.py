"""Small hand-made occupancy grids (y-up, True = obstacle) shared by the role engine tests."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from role_engine.core.environment import Environment

MAPS_DIR = Path(__file__).resolve().parents[3] / 'config' / 'roles' / 'maps'
RESOLUTION = 0.05
ORIGIN = (0.0, 0.0)


def empty_grid(ny: int = 40, nx: int = 40) -> np.ndarray:
    return np.zeros((ny, nx), dtype=bool)


def environment(grid: np.ndarray, **kwargs) -> Environment:
    return Environment(grid, RESOLUTION, ORIGIN, **kwargs)


def ring_corridor() -> np.ndarray:
    """A 40 x 40 room with a 20 x 20 block in the middle: a corridor loop around it."""
    grid = empty_grid()
    grid[10:30, 10:30] = True
    return grid


def two_rooms(door_cells: int) -> np.ndarray:
    """A 40 x 60 arena split by a wall at columns 29-30 with one door ``door_cells`` high."""
    grid = empty_grid(40, 60)
    grid[:, 29:31] = True
    start = 20 - door_cells // 2
    grid[start:start + door_cells, 29:31] = False
    return grid


def l_corridor() -> np.ndarray:
    """An L-shaped corridor 6 cells wide: up the left side, then right along the top."""
    grid = np.ones((40, 40), dtype=bool)
    grid[2:38, 2:8] = False
    grid[32:38, 2:38] = False
    return grid


def cell_centre(iy: float, ix: float) -> tuple[float, float]:
    """World point at the centre of cell (iy, ix) of these grids."""
    return ORIGIN[0] + (ix + 0.5) * RESOLUTION, ORIGIN[1] + (iy + 0.5) * RESOLUTION

"""Placement of a 2-D cell grid in the world, shared by the environment, SDF and E-Map.

Every grid of the role engine is a numpy array indexed ``[iy, ix]`` with ``iy`` growing
with world y ("y-up"), so cell ``(0, 0)`` is the bottom-left cell and ``origin`` is the
world position of its bottom-left corner. The centre of cell ``(iy, ix)`` is
``origin + ((ix + 0.5) * resolution, (iy + 0.5) * resolution)``. Images (row 0 at the
top) are flipped once when they are read (:func:`image_rows_to_grid`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .errors import RoleEngineError

#: Cost of one diagonal step on the 8-connected grid, in cells.
DIAGONAL_STEP = math.sqrt(2.0)


@dataclass(frozen=True)
class GridFrame:
    """Where a ``shape = (ny, nx)`` grid of square cells lies in the world."""

    resolution: float               # m per cell
    origin: tuple[float, float]     # world x, y of the bottom-left corner of cell (0, 0)
    shape: tuple[int, int]          # (ny, nx)

    def __post_init__(self) -> None:
        if not (math.isfinite(self.resolution) and self.resolution > 0.0):
            raise RoleEngineError(f'grid.resolution: must be a finite number > 0 (got {self.resolution})')
        if len(self.origin) != 2 or not all(math.isfinite(v) for v in self.origin):
            raise RoleEngineError(f'grid.origin: must be two finite numbers (got {self.origin})')
        if len(self.shape) != 2 or min(self.shape) < 1:
            raise RoleEngineError(f'grid.shape: must be two integers >= 1 (got {self.shape})')
        object.__setattr__(self, 'origin', (float(self.origin[0]), float(self.origin[1])))
        object.__setattr__(self, 'shape', (int(self.shape[0]), int(self.shape[1])))

    @classmethod
    def covering(cls, bounds, resolution: float) -> GridFrame:
        """The grid of ``resolution`` cells over world ``bounds`` (xmin, ymin, xmax, ymax)."""
        xmin, ymin, xmax, ymax = bounds
        return cls(resolution, (xmin, ymin), (int(round((ymax - ymin) / resolution)),
                                              int(round((xmax - xmin) / resolution))))

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) of the area the grid covers."""
        ny, nx = self.shape
        x0, y0 = self.origin
        return x0, y0, x0 + nx * self.resolution, y0 + ny * self.resolution

    def world_to_continuous(self, points: np.ndarray) -> np.ndarray:
        """(N, 2) world x, y -> (N, 2) fractional (ix, iy) with cell centres at integers."""
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        return (points - np.asarray(self.origin)) / self.resolution - 0.5

    def world_to_cell(self, points: np.ndarray) -> np.ndarray:
        """(N, 2) world x, y -> (N, 2) integer (iy, ix) of the containing cell (may be off-grid)."""
        fractional = self.world_to_continuous(points)
        return np.floor(fractional[:, ::-1] + 0.5).astype(int)

    def cell_to_world(self, cells: np.ndarray) -> np.ndarray:
        """(N, 2) (iy, ix), integer or fractional -> (N, 2) world x, y of the cell centres."""
        cells = np.asarray(cells, dtype=float).reshape(-1, 2)
        return np.asarray(self.origin) + (cells[:, ::-1] + 0.5) * self.resolution

    def contains_cells(self, cells: np.ndarray) -> np.ndarray:
        """(N,) bool: which (iy, ix) cells lie on the grid."""
        cells = np.asarray(cells).reshape(-1, 2)
        return ((cells[:, 0] >= 0) & (cells[:, 0] < self.shape[0])
                & (cells[:, 1] >= 0) & (cells[:, 1] < self.shape[1]))


def octile_distance(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Length in cells of the shortest 8-connected grid path between cells ``a`` and ``b``.

    It never exceeds the length of any 8-connected pixel chain between them, so it is
    an admissible and consistent A* heuristic for chain-length edge weights.
    """
    delta = np.abs(np.asarray(a, dtype=float) - np.asarray(b, dtype=float))
    small, large = np.min(delta, axis=-1), np.max(delta, axis=-1)
    return large + (DIAGONAL_STEP - 1.0) * small


def image_rows_to_grid(image: np.ndarray) -> np.ndarray:
    """An image array (row 0 at the top) as a y-up grid (row 0 at the bottom)."""
    return np.ascontiguousarray(np.flipud(image))


def segment_cells(start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """(K, 2) integer (iy, ix) cells whose interior the straight segment between two fractional cells crosses.

    Exact traversal: the segment is cut where it crosses cell boundaries (half-integer
    lines) and each piece's midpoint names its cell. A segment that passes exactly
    through a cell corner touches the two cells beside it without entering them, as an
    8-connected diagonal step does; the cells of both end points are always included.
    """
    start = np.asarray(start, dtype=float)
    end = np.asarray(end, dtype=float)
    delta = end - start
    cuts = [0.0, 1.0]
    for axis in range(2):
        if delta[axis] != 0.0:
            low, high = sorted((start[axis], end[axis]))
            boundaries = np.arange(math.floor(low + 0.5) + 0.5, high, 1.0)
            cuts.extend((boundaries - start[axis]) / delta[axis])
    cuts = np.sort(np.clip(cuts, 0.0, 1.0))
    # Crossings of a corner give two (numerically) equal cuts: merge them.
    cuts = cuts[np.concatenate([[True], np.diff(cuts) > 1e-9])]
    middles = (cuts[:-1] + cuts[1:]) / 2.0
    points = np.vstack([start, start + middles[:, None] * delta, end])
    cells = np.floor(points + 0.5).astype(int)
    keep = np.ones(len(cells), dtype=bool)
    keep[1:] = np.any(cells[1:] != cells[:-1], axis=1)
    return cells[keep]


def line_of_sight(free: np.ndarray, start_cell: np.ndarray, end_cell: np.ndarray) -> bool:
    """Whether the straight segment between two cell centres crosses only ``free`` cells."""
    cells = segment_cells(start_cell, end_cell)
    ny, nx = free.shape
    inside = (cells[:, 0] >= 0) & (cells[:, 0] < ny) & (cells[:, 1] >= 0) & (cells[:, 1] < nx)
    if not inside.all():
        return False
    return bool(free[cells[:, 0], cells[:, 1]].all())

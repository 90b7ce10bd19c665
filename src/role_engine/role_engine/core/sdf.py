"""Signed distance field (SDF) of an occupancy grid, with bilinear queries (Sec. IV-B, Fig. 6).

The field holds, at every cell centre, the distance in metres from that point to the
nearest obstacle surface: positive in free space, negative inside obstacles. The
obstacle surface is taken to be the cell boundary between occupied and free cells, so
the Euclidean distance transforms (between cell centres) are shifted by half a cell:
a free cell next to an obstacle is 0.5 cell away from it, an occupied cell next to free
space 0.5 cell inside. Grid conventions are those of :mod:`.grid` (``data[iy, ix]``,
``origin`` = bottom-left corner of cell (0, 0)).
"""
from __future__ import annotations

import numpy as np
from scipy import ndimage

from .errors import RoleEngineError
from .grid import GridFrame


def signed_distance_cells(occupied: np.ndarray, *, border_is_obstacle: bool = False) -> np.ndarray:
    """Signed distance in cells from every cell centre to the nearest obstacle surface.

    ``border_is_obstacle`` treats everything beyond the grid as occupied (an arena whose
    edge is a wall). A grid with no obstacle (or no free cell) at all has no surface;
    its distance is then the grid diagonal everywhere (negated when fully occupied), a
    finite stand-in for "farther than anything on the map".
    """
    occupied = np.asarray(occupied, dtype=bool)
    if occupied.ndim != 2 or occupied.size == 0:
        raise RoleEngineError(f'occupancy: must be a non-empty 2-D array (got shape {occupied.shape})')
    grid = np.pad(occupied, 1, constant_values=True) if border_is_obstacle else occupied
    diagonal = float(np.hypot(*grid.shape))
    if not grid.any():
        field = np.full(grid.shape, diagonal)
    elif grid.all():
        field = np.full(grid.shape, -diagonal)
    else:
        outside = ndimage.distance_transform_edt(~grid)   # free cell -> nearest occupied centre
        inside = ndimage.distance_transform_edt(grid)     # occupied cell -> nearest free centre
        field = np.where(grid, -(inside - 0.5), outside - 0.5)
    return field[1:-1, 1:-1] if border_is_obstacle else field


class SignedDistanceField:
    """Signed distances on a grid, queried in world metres with bilinear interpolation.

    Attributes (the interface the GP planner relies on): ``resolution`` (m per cell),
    ``origin`` (world x, y of the bottom-left corner of cell (0, 0)), ``shape``
    (``(ny, nx)``) and ``data`` (``(ny, nx)`` distances in m at the cell centres).
    """

    def __init__(self, distances: np.ndarray, resolution: float, origin: tuple[float, float]):
        data = np.array(distances, dtype=float)
        if data.ndim != 2 or data.size == 0:
            raise RoleEngineError(f'sdf.distances: must be a non-empty 2-D array (got shape {data.shape})')
        if not np.isfinite(data).all():
            raise RoleEngineError('sdf.distances: every distance must be finite')
        self.frame = GridFrame(float(resolution), tuple(origin), data.shape)
        self.resolution = self.frame.resolution
        self.origin = self.frame.origin
        self.shape = self.frame.shape
        self.data = data
        self.data.setflags(write=False)

    @classmethod
    def from_occupancy(cls, occupied: np.ndarray, resolution: float, origin: tuple[float, float],
                       *, border_is_obstacle: bool = False) -> SignedDistanceField:
        """SDF of a boolean y-up occupancy grid (True = obstacle), in metres."""
        cells = signed_distance_cells(occupied, border_is_obstacle=border_is_obstacle)
        return cls(cells * float(resolution), resolution, origin)

    def query(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Signed distance (N,) in m and its gradient (N, 2) in world x, y at (N, 2) world points.

        The distance is the bilinear interpolation of the cell-centre samples and the
        gradient is the exact derivative of that interpolant, so the two agree for a
        numerical Jacobian check (the gradient jumps across cell-centre lines).

        Points outside the area spanned by the cell centres (the outer half cell and
        anything beyond the map) are clamped onto that area; the distance is extended
        linearly from the clamped point along its gradient (first-order Taylor), and the
        gradient is the clamped point's. With ``border_is_obstacle`` this makes points
        beyond the arena edge get a negative distance that keeps decreasing outward.
        """
        points = np.asarray(points, dtype=float)
        if points.ndim == 1 and points.shape == (2,):
            points = points[None, :]
        if points.ndim != 2 or points.shape[1] != 2:
            raise RoleEngineError(f'sdf.query points: must have shape (N, 2) (got {points.shape})')
        if not np.isfinite(points).all():
            raise RoleEngineError('sdf.query points: every coordinate must be finite')
        ny, nx = self.shape
        continuous = self.frame.world_to_continuous(points)
        fx = np.clip(continuous[:, 0], 0.0, nx - 1.0)
        fy = np.clip(continuous[:, 1], 0.0, ny - 1.0)
        ix0 = np.minimum(np.floor(fx).astype(int), max(nx - 2, 0))
        iy0 = np.minimum(np.floor(fy).astype(int), max(ny - 2, 0))
        ix1 = np.minimum(ix0 + 1, nx - 1)
        iy1 = np.minimum(iy0 + 1, ny - 1)
        tx = fx - ix0
        ty = fy - iy0
        d00 = self.data[iy0, ix0]
        d01 = self.data[iy0, ix1]
        d10 = self.data[iy1, ix0]
        d11 = self.data[iy1, ix1]
        distance = (1 - ty) * ((1 - tx) * d00 + tx * d01) + ty * ((1 - tx) * d10 + tx * d11)
        gradient = np.empty((len(points), 2))
        gradient[:, 0] = ((1 - ty) * (d01 - d00) + ty * (d11 - d10)) / self.resolution
        gradient[:, 1] = ((1 - tx) * (d10 - d00) + tx * (d11 - d01)) / self.resolution
        # Offset from the clamped point, in metres, for the linear extension beyond the samples.
        offset = np.stack([continuous[:, 0] - fx, continuous[:, 1] - fy], axis=1) * self.resolution
        distance = distance + np.sum(gradient * offset, axis=1)
        return distance, gradient

    def distance(self, points: np.ndarray) -> np.ndarray:
        """Signed distance only (see :meth:`query`)."""
        return self.query(points)[0]

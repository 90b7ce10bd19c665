"""The environment from one top-view image (Sec. III-A).

The camera model (pixel <-> ground) is the workspace's shared
:class:`collab_tools.core.camera_geometry.TopViewGeometry`.

Obstacle segmentation: the arena floor is known by its colours (given, or estimated as
the most frequent colours of the image, e.g. the two tiles of a checkerboard); every
other pixel is an obstacle, except inside the discs of the robots themselves (agents are
not obstacles; their positions come from colour tracking). The grid is sampled at each
cell's centre and near its four corners, and a cell is occupied when any sample is, so thin
obstacles are not lost; samples that fall outside the image are occupied (unknown space
is not free). An obstacle's visible sides make its footprint grow toward the image
centre by height x offset / altitude (a few cm in the bridge's arena): conservative.
"""
from __future__ import annotations

import math

import cv2
import numpy as np

from collab_tools.core.camera_geometry import TopViewGeometry

from .environment import Environment
from .errors import RoleEngineError
from .grid import GridFrame


def check_rgb(image: np.ndarray) -> np.ndarray:
    image = np.asarray(image)
    if image.ndim != 3 or image.shape[2] != 3 or image.dtype != np.uint8 or image.size == 0:
        raise RoleEngineError(f'image: must be an (H, W, 3) uint8 RGB image (got {image.dtype} {image.shape})')
    return image


def estimate_floor_colors(rgb: np.ndarray, count: int = 2, quantum: int = 8) -> np.ndarray:
    """(count, 3) the most frequent colours of the image (quantised to ``quantum`` levels)."""
    rgb = check_rgb(rgb)
    quantised = (rgb.reshape(-1, 3) // quantum).astype(np.int64)
    keys = (quantised[:, 0] << 16) | (quantised[:, 1] << 8) | quantised[:, 2]
    values, counts = np.unique(keys, return_counts=True)
    top = values[np.argsort(-counts)[:count]]
    colors = []
    for key in top:
        members = rgb.reshape(-1, 3)[keys == key]
        colors.append(members.mean(axis=0))
    return np.array(colors)


def segment_obstacles(rgb: np.ndarray, floor_colors: np.ndarray, *, tolerance: float = 40.0,
                      free_mask: np.ndarray | None = None) -> np.ndarray:
    """(H, W) bool: pixels farther than ``tolerance`` (RGB distance) from every floor colour.

    ``free_mask`` marks pixels known to be free whatever their colour (the robots' discs).
    """
    rgb = check_rgb(rgb).astype(float)
    floor = np.asarray(floor_colors, dtype=float).reshape(-1, 3)
    if len(floor) == 0 or not np.isfinite(floor).all():
        raise RoleEngineError('floor_colors: need at least one finite RGB colour')
    distance = np.min(np.linalg.norm(rgb[:, :, None, :] - floor[None, None, :, :], axis=3), axis=2)
    obstacle = distance > tolerance
    if free_mask is not None:
        obstacle &= ~np.asarray(free_mask, dtype=bool)
    return obstacle


def robot_disc_mask(shape: tuple[int, int], geometry: TopViewGeometry,
                    discs: list[tuple[float, ...]], *, margin_px: int = 2) -> np.ndarray:
    """(H, W) bool: the image footprint of upright robot cylinders, grown by ``margin_px``.

    Each disc is (x, y, radius) or (x, y, radius, height); the footprint covers the top
    and bottom discs and the side between them, as the camera sees it.
    """
    mask = np.zeros(shape, dtype=np.uint8)
    for disc in discs:
        x, y, radius = disc[:3]
        height = disc[3] if len(disc) > 3 else 0.0
        ends = []
        for z in (0.0, height):
            (u, v), = geometry.world_to_pixel(np.array([[x, y]]), z)
            edge, = geometry.world_to_pixel(np.array([[x + radius, y]]), z)
            pixels = int(math.ceil(math.hypot(edge[0] - u, edge[1] - v))) + margin_px
            centre = (int(round(u)), int(round(v)))
            cv2.circle(mask, centre, pixels, 1, thickness=-1)
            ends.append((centre, pixels))
        cv2.line(mask, ends[0][0], ends[1][0], 1, thickness=2 * min(ends[0][1], ends[1][1]) + 1)
    return mask.astype(bool)


def environment_from_top_view(rgb: np.ndarray, geometry: TopViewGeometry, frame: GridFrame, *,
                              floor_colors: np.ndarray | None = None, tolerance: float = 40.0,
                              robot_discs: list[tuple[float, ...]] = (),
                              border_is_obstacle: bool = True, name: str = 'top_view') -> Environment:
    """The environment ``e`` seen by the camera, on the grid ``frame`` (see module docstring)."""
    rgb = check_rgb(rgb)
    colors = estimate_floor_colors(rgb) if floor_colors is None else np.asarray(floor_colors, dtype=float)
    free = robot_disc_mask(rgb.shape[:2], geometry, list(robot_discs)) if robot_discs else None
    obstacle = segment_obstacles(rgb, colors, tolerance=tolerance, free_mask=free)
    ny, nx = frame.shape
    iy, ix = np.mgrid[0:ny, 0:nx]
    occupied = np.zeros((ny, nx), dtype=bool)
    height, width = obstacle.shape
    # Centre and corners; corners pulled in a little so the edge cells do not see beyond the grid.
    for dy, dx in ((0.0, 0.0), (-0.4, -0.4), (-0.4, 0.4), (0.4, -0.4), (0.4, 0.4)):
        cells = np.column_stack([(iy + dy).ravel(), (ix + dx).ravel()])
        pixels = np.rint(geometry.world_to_pixel(frame.cell_to_world(cells))).astype(int)
        inside = (pixels[:, 0] >= 0) & (pixels[:, 0] < width) & (pixels[:, 1] >= 0) & (pixels[:, 1] < height)
        sample = np.ones(len(cells), dtype=bool)
        sample[inside] = obstacle[pixels[inside, 1], pixels[inside, 0]]
        occupied |= sample.reshape(ny, nx)
    return Environment(occupied, frame.resolution, frame.origin, border_is_obstacle=border_is_obstacle, name=name)

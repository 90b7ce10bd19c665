"""The top-view camera: pixel <-> ground geometry, and the environment from one image (Sec. III-A).

Geometry follows ROS/OpenCV pinhole conventions (pixel centres at integer (u, v), ``K``
from ``CameraInfo``) and the camera pose from the bridge's ``/<camera>/pose`` (optical
frame x right, y down, z forward, in the world). The bridge's camera looks straight down
with image right = world +x and image up = world +y (orientation xyzw ``(1, 0, 0, 0)``),
but any pose works.

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
from dataclasses import dataclass

import cv2
import numpy as np

from .environment import Environment
from .errors import RoleEngineError
from .grid import GridFrame

#: Orientation (x, y, z, w) of the bridge camera's optical frame when looking straight down.
LOOKING_DOWN_XYZW = (1.0, 0.0, 0.0, 0.0)


def _rotation_from_quaternion(xyzw) -> np.ndarray:
    x, y, z, w = (float(v) for v in xyzw)
    norm = math.sqrt(x * x + y * y + z * z + w * w)
    if not math.isfinite(norm) or norm < 1e-9:
        raise RoleEngineError(f'camera orientation: must be a non-zero finite quaternion (got {xyzw})')
    x, y, z, w = x / norm, y / norm, z / norm, w / norm
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


@dataclass(frozen=True)
class TopViewGeometry:
    """Pinhole camera above the ground: intrinsics ``K`` (3x3) and the optical frame's world pose."""

    intrinsics: np.ndarray
    position: tuple[float, float, float]
    orientation_xyzw: tuple[float, float, float, float] = LOOKING_DOWN_XYZW

    def __post_init__(self) -> None:
        k = np.asarray(self.intrinsics, dtype=float).reshape(3, 3)
        if not np.isfinite(k).all() or k[0, 0] <= 0 or k[1, 1] <= 0:
            raise RoleEngineError(f'camera K: focal lengths must be finite and > 0 (got {k.ravel().tolist()})')
        object.__setattr__(self, 'intrinsics', k)
        object.__setattr__(self, '_rotation', _rotation_from_quaternion(self.orientation_xyzw))
        if len(self.position) != 3 or not all(math.isfinite(v) for v in self.position):
            raise RoleEngineError(f'camera position: must be three finite numbers (got {self.position})')

    @classmethod
    def from_camera_info(cls, k, position, orientation_xyzw=LOOKING_DOWN_XYZW) -> TopViewGeometry:
        """From ``CameraInfo.k`` (9 numbers, row-major) and the camera pose."""
        k = np.asarray(k, dtype=float)
        if k.size != 9:
            raise RoleEngineError(f'camera K: must have 9 entries (got {k.size})')
        return cls(k.reshape(3, 3), tuple(float(v) for v in position), tuple(orientation_xyzw))

    def world_to_pixel(self, points: np.ndarray, z: float = 0.0) -> np.ndarray:
        """(N, 2) world x, y at height ``z`` -> (N, 2) pixel (u, v)."""
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        world = np.column_stack([points, np.full(len(points), z)]) - np.asarray(self.position)
        optical = world @ self._rotation            # R^T applied to each row
        if (optical[:, 2] <= 0).any():
            raise RoleEngineError('world_to_pixel: a point lies behind the camera')
        projected = optical @ self.intrinsics.T
        return projected[:, :2] / projected[:, 2:3]

    def pixel_to_world(self, pixels: np.ndarray, z: float = 0.0) -> np.ndarray:
        """(N, 2) pixel (u, v) -> (N, 2) world x, y where its ray meets the plane at height ``z``."""
        pixels = np.asarray(pixels, dtype=float).reshape(-1, 2)
        rays = np.column_stack([pixels, np.ones(len(pixels))]) @ np.linalg.inv(self.intrinsics).T
        directions = rays @ self._rotation.T
        if (np.abs(directions[:, 2]) < 1e-12).any():
            raise RoleEngineError('pixel_to_world: a pixel ray is parallel to the ground')
        scale = (z - self.position[2]) / directions[:, 2]
        if (scale <= 0).any():
            raise RoleEngineError(f'pixel_to_world: the plane z={z} is not in front of the camera')
        return np.asarray(self.position[:2]) + scale[:, None] * directions[:, :2]

    def metres_per_pixel(self, z: float = 0.0) -> float:
        """Ground size of one pixel at the image centre (for pixel thresholds in metres)."""
        centre = np.array([[self.intrinsics[0, 2], self.intrinsics[1, 2]]])
        a, b = self.pixel_to_world(np.vstack([centre, centre + [1.0, 0.0]]), z)
        return float(np.hypot(*(b - a)))


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

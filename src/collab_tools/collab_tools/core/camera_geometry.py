"""Pinhole geometry of the top-view camera: pixel <-> world on horizontal planes.

One model for everyone who looks at the bridge's camera: the bridge renders with it,
the SGCM perception and the role engine's tracker and map segmentation read images
with it. Conventions are ROS/OpenCV's: pixel centres at integer (u, v) = (column,
row), ``K`` as in ``CameraInfo.k``, and the pose of the optical frame (x right,
y down, z forward) in the world, as the bridge publishes on ``/<camera>/pose``. The
bridge's camera looks straight down with image right = world +x and image up =
world +y (orientation xyzw ``(1, 0, 0, 0)``), but any pose works.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: Orientation (x, y, z, w) of the optical frame in the world when looking straight down:
#: a half turn about world x.
LOOKING_DOWN_XYZW = (1.0, 0.0, 0.0, 0.0)


class CameraGeometryError(ValueError):
    """Invalid camera parameters or a point the camera cannot map."""


def rotation_from_quaternion(xyzw) -> np.ndarray:
    """3x3 rotation matrix of a unit quaternion (x, y, z, w); normalised first."""
    x, y, z, w = (float(v) for v in xyzw)
    norm = math.sqrt(x * x + y * y + z * z + w * w)
    if not math.isfinite(norm) or norm < 1e-9:
        raise CameraGeometryError(f'camera orientation: must be a non-zero finite quaternion (got {xyzw})')
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
            raise CameraGeometryError(f'camera K: focal lengths must be finite and > 0 (got {k.ravel().tolist()})')
        object.__setattr__(self, 'intrinsics', k)
        object.__setattr__(self, '_rotation', rotation_from_quaternion(self.orientation_xyzw))
        if len(self.position) != 3 or not all(math.isfinite(v) for v in self.position):
            raise CameraGeometryError(f'camera position: must be three finite numbers (got {self.position})')

    @classmethod
    def from_camera_info(cls, k, position, orientation_xyzw=LOOKING_DOWN_XYZW) -> TopViewGeometry:
        """From ``CameraInfo.k`` (9 numbers, row-major) and the camera pose."""
        k = np.asarray(k, dtype=float)
        if k.size != 9:
            raise CameraGeometryError(f'camera K: must have 9 entries (got {k.size})')
        return cls(k.reshape(3, 3), tuple(float(v) for v in position), tuple(orientation_xyzw))

    def world_to_pixel(self, points: np.ndarray, z: float = 0.0) -> np.ndarray:
        """(N, 2) world x, y at height ``z`` -> (N, 2) pixel (u, v)."""
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        world = np.column_stack([points, np.full(len(points), z)]) - np.asarray(self.position)
        optical = world @ self._rotation            # R^T applied to each row
        if (optical[:, 2] <= 0).any():
            raise CameraGeometryError(f'world_to_pixel: a point at z={z} lies behind the camera')
        projected = optical @ self.intrinsics.T
        return projected[:, :2] / projected[:, 2:3]

    def pixel_to_world(self, pixels: np.ndarray, z: float = 0.0) -> np.ndarray:
        """(N, 2) pixel (u, v) -> (N, 2) world x, y where its ray meets the plane at height ``z``."""
        pixels = np.asarray(pixels, dtype=float).reshape(-1, 2)
        rays = np.column_stack([pixels, np.ones(len(pixels))]) @ np.linalg.inv(self.intrinsics).T
        directions = rays @ self._rotation.T
        if (np.abs(directions[:, 2]) < 1e-12).any():
            raise CameraGeometryError('pixel_to_world: a pixel ray is parallel to the ground')
        scale = (z - self.position[2]) / directions[:, 2]
        if (scale <= 0).any():
            raise CameraGeometryError(f'pixel_to_world: the plane z={z} is not in front of the camera')
        return np.asarray(self.position[:2]) + scale[:, None] * directions[:, :2]

    def metres_per_pixel(self, z: float = 0.0) -> float:
        """Ground size of one pixel at the image centre (for pixel thresholds in metres)."""
        centre = np.array([[self.intrinsics[0, 2], self.intrinsics[1, 2]]])
        a, b = self.pixel_to_world(np.vstack([centre, centre + [1.0, 0.0]]), z)
        return float(np.hypot(*(b - a)))

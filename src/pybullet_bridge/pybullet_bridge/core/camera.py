"""Top-view pinhole camera looking straight down at the arena.

Pixel coordinates follow ROS/OpenCV: (u, v) = (column, row) with integer values
at pixel centres, so the principal point of the symmetric pybullet frustum is
((W - 1) / 2, (H - 1) / 2). Image right is world +x, image up is world +y. Pixel <-> world
mapping is the workspace's shared model (collab_tools.core.camera_geometry), the one the
nodes rebuild from CameraInfo and the camera pose.
"""
from __future__ import annotations

import math
from typing import Callable

import numpy as np
import pybullet as p
from collab_tools.core.camera_geometry import LOOKING_DOWN_XYZW, TopViewGeometry

from .world import CameraConfig

#: pybullet packs the link index above bit 24 of segmentation values.
_OBJECT_UID_MASK = (1 << 24) - 1


class TopViewCamera:
    def __init__(self, config: CameraConfig):
        self.config = config
        self.width = config.width
        self.height = config.height
        self.frame_id = config.frame_id
        self.center = (float(config.center[0]), float(config.center[1]))
        self.altitude = float(config.altitude)
        # Square pixels: the vertical fov fixes the focal length for both axes.
        self.focal = self.height / (2.0 * math.tan(math.radians(config.fov_deg) / 2.0))
        self.cx = (self.width - 1) / 2.0
        self.cy = (self.height - 1) / 2.0
        # Clip planes bracket the ground; 1 cm keeps depth precision without clipping tall bodies.
        self.near = 0.01
        self.far = self.altitude + 1.0
        self._view = p.computeViewMatrix(
            cameraEyePosition=[*self.center, self.altitude],
            cameraTargetPosition=[*self.center, 0.0],
            cameraUpVector=[0.0, 1.0, 0.0])
        self._projection = p.computeProjectionMatrixFOV(
            fov=config.fov_deg, aspect=self.width / self.height, nearVal=self.near, farVal=self.far)
        self.geometry = TopViewGeometry(self.intrinsics(), *self.optical_pose())

    def intrinsics(self) -> np.ndarray:
        """3x3 camera matrix K."""
        return np.array([[self.focal, 0.0, self.cx],
                         [0.0, self.focal, self.cy],
                         [0.0, 0.0, 1.0]])

    def projection(self) -> np.ndarray:
        """3x4 projection matrix P = [K | 0] (monocular camera)."""
        return np.hstack([self.intrinsics(), np.zeros((3, 1))])

    def optical_pose(self) -> tuple[tuple[float, float, float], tuple[float, float, float, float]]:
        """Position and xyzw orientation of the optical frame in the world."""
        return (self.center[0], self.center[1], self.altitude), LOOKING_DOWN_XYZW

    def world_to_pixel(self, x: float, y: float, z: float = 0.0) -> tuple[float, float]:
        """Pixel (u, v) where the world point appears."""
        (u, v), = self.geometry.world_to_pixel(np.array([[x, y]]), z)
        return float(u), float(v)

    def pixel_to_world(self, u: float, v: float, z: float = 0.0) -> tuple[float, float]:
        """World (x, y) on the horizontal plane at height ``z`` seen at pixel (u, v)."""
        (x, y), = self.geometry.pixel_to_world(np.array([[u, v]]), z)
        return float(x), float(y)

    def ground_footprint(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) of the ground area the image covers."""
        x0, y1 = self.pixel_to_world(-0.5, -0.5)
        x1, y0 = self.pixel_to_world(self.width - 0.5, self.height - 0.5)
        return x0, y0, x1, y1

    def render(self, client: int,
               label_of_body: Callable[[int], int] | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Render (rgb (H, W, 3) uint8, labels (H, W) uint16) with the client's renderer.

        TinyRenderer unless the client loaded the EGL plugin (core/renderer.py), which then draws
        every getCameraImage whatever its ``renderer`` argument.

        ``label_of_body`` maps a pybullet body unique id to its label, either as a
        function or as a lookup array indexed by id; unknown ids map to 0.
        """
        _, _, rgba, _, segmentation = p.getCameraImage(
            self.width, self.height, self._view, self._projection,
            shadow=0, renderer=p.ER_TINY_RENDERER, physicsClientId=client)
        rgb = np.asarray(rgba, dtype=np.uint8).reshape(self.height, self.width, 4)[:, :, :3].copy()
        segmentation = np.asarray(segmentation, dtype=np.int64).reshape(self.height, self.width)
        seen = segmentation >= 0  # -1 where no body is hit
        uids = np.where(seen, segmentation & _OBJECT_UID_MASK, 0)
        if isinstance(label_of_body, np.ndarray):
            lookup = np.asarray(label_of_body, dtype=np.uint16)
        else:
            lookup = np.array([label_of_body(uid) for uid in range(int(uids.max()) + 1)], dtype=np.uint16)
        padded = np.zeros(max(int(uids.max()) + 1, len(lookup)), dtype=np.uint16)
        padded[:len(lookup)] = lookup
        labels = np.where(seen, padded[uids], 0).astype(np.uint16)
        return rgb, labels

"""The top-view camera as the role nodes see it: the newest RGB frame and its geometry.

Keeps the latest image, intrinsics and pose from the bridge's latched topics and turns
them into a numpy image and a :class:`~.core.top_view.TopViewGeometry`.
"""
from __future__ import annotations

import numpy as np
from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.time import Time
from sensor_msgs.msg import CameraInfo, Image
from collab_tools.images import image_array

from .core.top_view import TopViewGeometry


class CameraView:
    def __init__(self, node: Node, camera: str = 'top_camera', on_frame=None):
        self._image: Image | None = None
        self._info: CameraInfo | None = None
        self._pose: PoseStamped | None = None
        self._geometry: TopViewGeometry | None = None
        self._on_frame = on_frame
        latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL)
        ns = '/' + camera.strip('/')
        node.create_subscription(Image, f'{ns}/image_raw', self._on_image, latched)
        node.create_subscription(CameraInfo, f'{ns}/camera_info', self._on_info, latched)
        node.create_subscription(PoseStamped, f'{ns}/pose', self._on_pose, latched)

    def _on_image(self, msg: Image) -> None:
        self._image = msg
        if self._on_frame is not None and self.ready():
            self._on_frame()

    def _on_info(self, msg: CameraInfo) -> None:
        self._info, self._geometry = msg, None

    def _on_pose(self, msg: PoseStamped) -> None:
        self._pose, self._geometry = msg, None

    def ready(self) -> bool:
        return self._image is not None and self._info is not None and self._pose is not None

    def geometry(self) -> TopViewGeometry:
        if self._geometry is None:
            p, q = self._pose.pose.position, self._pose.pose.orientation
            self._geometry = TopViewGeometry.from_camera_info(self._info.k, (p.x, p.y, p.z), (q.x, q.y, q.z, q.w))
        return self._geometry

    def frame(self) -> tuple[Time, np.ndarray]:
        """Stamp and RGB array of the newest frame; ValueError if it cannot be used."""
        if not self.ready():
            raise ValueError('no camera frame yet')
        return Time.from_msg(self._image.header.stamp), image_array(self._image)

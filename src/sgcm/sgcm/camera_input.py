"""The top-view camera as the SGCM nodes see it: labelled frames and their geometry.

Keeps the latest RGB and label images (matched by stamp), the camera's intrinsics and
pose, and the label legend (which labels are cubes), all from the bridge's latched
topics, and turns a frame into a state estimate with sgcm.core.perception.
"""
from __future__ import annotations

import numpy as np
from bridge_interfaces.msg import LabelLegend
from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.time import Time
from sensor_msgs.msg import CameraInfo, Image

from collab_tools.images import image_array

from .core.perception import PinholeView, StateEstimate, estimate_state
from .core.task_config import TaskConfig

CUBE_KIND = 'cube'


class CameraInput:
    def __init__(self, node: Node, task: TaskConfig, camera: str = 'top_camera'):
        self.node = node
        self.task = task
        self._rgb: Image | None = None
        self._labels: Image | None = None
        self._info: CameraInfo | None = None
        self._pose: PoseStamped | None = None
        self.cube_labels: dict[int, str] = {}
        latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL)
        ns = '/' + camera.strip('/')
        node.create_subscription(Image, f'{ns}/image_raw', self._on_rgb, latched)
        node.create_subscription(Image, f'{ns}/labels', self._on_labels, latched)
        node.create_subscription(CameraInfo, f'{ns}/camera_info', self._on_info, latched)
        node.create_subscription(PoseStamped, f'{ns}/pose', self._on_pose, latched)
        node.create_subscription(LabelLegend, f'{ns}/label_legend', self._on_legend, latched)

    def _on_rgb(self, msg: Image) -> None:
        self._rgb = msg

    def _on_labels(self, msg: Image) -> None:
        self._labels = msg

    def _on_info(self, msg: CameraInfo) -> None:
        self._info = msg

    def _on_pose(self, msg: PoseStamped) -> None:
        self._pose = msg

    def _on_legend(self, msg: LabelLegend) -> None:
        self.cube_labels = {entry.label: entry.name for entry in msg.entries if entry.kind == CUBE_KIND}

    def frame_time(self) -> Time | None:
        """Stamp of the newest complete (RGB + labels with equal stamps) frame."""
        if self._rgb is None or self._labels is None or self._info is None or self._pose is None:
            return None
        if self._rgb.header.stamp != self._labels.header.stamp:
            return None
        return Time.from_msg(self._labels.header.stamp)

    def estimate(self) -> StateEstimate:
        """State estimate from the newest complete frame; ValueError if it cannot be used."""
        if self.frame_time() is None:
            raise ValueError('no complete camera frame yet')
        k = self._info.k
        position = self._pose.pose.position
        view = PinholeView(fx=k[0], fy=k[4], cx=k[2], cy=k[5],
                           camera_x=position.x, camera_y=position.y, camera_z=position.z)
        ws = self.task.workspace
        return estimate_state(image_array(self._labels), image_array(self._rgb), self.cube_labels, view,
                              self.task, top_height=ws.table_height + ws.cube_size)

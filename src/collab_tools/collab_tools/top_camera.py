"""The bridge's top-view camera as a node sees it: the newest frame and its geometry.

Subscribes to the camera's topics (``<camera>/image_raw``, ``camera_info`` and, when asked, the
per-pixel ``labels`` image, with sensor-data QoS so a best-effort camera driver is accepted; the
latched ``pose`` and ``label_legend``), keeps the
newest of each and turns them into numpy images and a
:class:`~collab_tools.core.camera_geometry.TopViewGeometry`. A frame is complete when the
RGB image, intrinsics and pose are there and, with labels, the label image carries the
same stamp as the RGB one.

``transport='compressed'`` reads image_transport's compressed topics instead
(``image_raw/compressed`` JPEG, ``labels/compressed`` lossless PNG; see
:mod:`collab_tools.core.image_codec`): the same arrays (labels identical, RGB within JPEG
error) for a fraction of the bytes, for a node on another host. A message is decoded only
when its frame is used.
"""
from __future__ import annotations

import math
from typing import Callable

import numpy as np
from bridge_interfaces.msg import LabelLegend
from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from rclpy.time import Time
from sensor_msgs.msg import CameraInfo, CompressedImage, Image

from .core.camera_geometry import TopViewGeometry
from .core.image_codec import decode_labels, decode_rgb
from .images import image_array
from .core.input_checks import MalformedInput
from .input_guard import InputGuard, check_stamp
from .qos import LATCHED, SENSOR_IN


def check_camera_pose(msg: PoseStamped) -> None:
    """MalformedInput unless the camera pose is finite with a non-zero quaternion (and a valid stamp)."""
    check_stamp(msg.header.stamp)
    p, q = msg.pose.position, msg.pose.orientation
    values = (p.x, p.y, p.z, q.x, q.y, q.z, q.w)
    if not all(math.isfinite(v) for v in values) or not any((q.x, q.y, q.z, q.w)):
        raise MalformedInput(f'camera pose: position and orientation must be finite and set (got {values})',
                             kind='camera pose: not finite')


def check_camera_info(msg: CameraInfo) -> None:
    """MalformedInput unless the intrinsics K are 9 finite numbers with positive focal lengths."""
    k = list(msg.k)
    if len(k) != 9 or not all(math.isfinite(v) for v in k) or k[0] <= 0 or k[4] <= 0:
        raise MalformedInput(f'camera_info.k: must be 9 finite numbers with fx, fy > 0 (got {k[:9]})',
                             kind='camera_info.k: invalid')


#: image_transport transports TopCamera reads ('raw': sensor_msgs/Image; 'compressed': CompressedImage).
TRANSPORTS = ('raw', 'compressed')


class TopCamera:
    def __init__(self, node: Node, camera: str = '/top_camera', *, with_labels: bool = False,
                 on_frame: Callable[[], None] | None = None, transport: str = 'raw'):
        if transport not in TRANSPORTS:
            raise ValueError(f"image transport '{transport}' (expected one of {', '.join(TRANSPORTS)})")
        self.transport = transport
        self._rgb: Image | CompressedImage | None = None
        self._labels: Image | CompressedImage | None = None
        self._decoded: dict[str, tuple[object, np.ndarray]] = {}   # 'rgb'/'labels' -> (message, array)
        self._info: CameraInfo | None = None
        self._pose: PoseStamped | None = None
        self._geometry: TopViewGeometry | None = None
        self._with_labels = with_labels
        self._on_frame = on_frame
        #: label -> (entity name, kind) from the legend (with_labels only)
        self.legend: dict[int, tuple[str, str]] = {}
        # camera: the camera's namespace, absolute (a team-shared sensor: names.RobotNode.team('top_camera'))
        ns = '/' + camera.strip('/')
        # image_transport's topic names: <base topic>/<transport>, raw = the base topic itself.
        # Through the node's input guard: an image with an invalid stamp is dropped, counted and logged
        # once per kind, so frame_time can convert the stamps it keeps.
        self._inputs = inputs = InputGuard.of(node)
        kind, suffix = (Image, '') if transport == 'raw' else (CompressedImage, '/compressed')
        inputs.subscribe(kind, f'{ns}/image_raw{suffix}', self._on_rgb, SENSOR_IN)
        inputs.subscribe(CameraInfo, f'{ns}/camera_info', self._on_info, SENSOR_IN)
        inputs.subscribe(PoseStamped, f'{ns}/pose', self._on_pose, LATCHED)
        if with_labels:
            inputs.subscribe(kind, f'{ns}/labels{suffix}', self._on_labels, SENSOR_IN)
            inputs.subscribe(LabelLegend, f'{ns}/label_legend', self._on_legend, LATCHED)

    def _on_rgb(self, msg: Image | CompressedImage) -> None:
        self._inputs.stamp(msg.header.stamp)     # MalformedInput: dropped by the guard
        self._rgb = msg
        self._notify()

    def _on_labels(self, msg: Image | CompressedImage) -> None:
        self._inputs.stamp(msg.header.stamp)
        self._labels = msg
        self._notify()

    def _on_info(self, msg: CameraInfo) -> None:
        check_camera_info(msg)
        self._info, self._geometry = msg, None

    def _on_pose(self, msg: PoseStamped) -> None:
        check_camera_pose(msg)     # a NaN pose must not replace the latched good one
        self._pose, self._geometry = msg, None

    def _on_legend(self, msg: LabelLegend) -> None:
        self.legend = {entry.label: (entry.name, entry.kind) for entry in msg.entries}

    def _notify(self) -> None:
        if self._on_frame is not None and self.frame_time() is not None:
            self._on_frame()

    def frame_time(self) -> Time | None:
        """Stamp of the newest complete frame, None while there is none."""
        if self._rgb is None or self._info is None or self._pose is None:
            return None
        if self._with_labels and (self._labels is None or self._labels.header.stamp != self._rgb.header.stamp):
            return None
        return Time.from_msg(self._rgb.header.stamp)

    def ready(self) -> bool:
        return self.frame_time() is not None

    def geometry(self) -> TopViewGeometry:
        """The camera model from the latest intrinsics and pose (ValueError before they arrive)."""
        if self._info is None or self._pose is None:
            raise ValueError('no camera_info and pose yet')
        if self._geometry is None:
            p, q = self._pose.pose.position, self._pose.pose.orientation
            self._geometry = TopViewGeometry.from_camera_info(self._info.k, (p.x, p.y, p.z), (q.x, q.y, q.z, q.w))
        return self._geometry

    def frame(self) -> tuple[Time, np.ndarray]:
        """Stamp and RGB array of the newest complete frame; ValueError if it cannot be used."""
        stamp = self.frame_time()
        if stamp is None:
            raise ValueError('no complete camera frame yet')
        return stamp, self._array('rgb', self._rgb)

    def labels(self) -> np.ndarray:
        """Label image of the newest complete frame (with_labels only); ValueError if it cannot be used."""
        if not self._with_labels:
            raise ValueError('this TopCamera was created without labels')
        if self.frame_time() is None:
            raise ValueError('no complete camera frame yet')
        return self._array('labels', self._labels)

    def _array(self, which: str, msg: Image | CompressedImage) -> np.ndarray:
        if isinstance(msg, Image):
            return image_array(msg)
        cached = self._decoded.get(which)
        if cached is not None and cached[0] is msg:
            return cached[1].copy()
        decode = decode_rgb if which == 'rgb' else decode_labels
        array = decode(msg.format, msg.data)
        self._decoded[which] = (msg, array)
        return array.copy()

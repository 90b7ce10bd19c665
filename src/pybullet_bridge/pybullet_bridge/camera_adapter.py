"""The bridge's top-view camera on ROS: streamed to subscribers, compressed as image_transport does it, or on demand.

Nothing is rendered for nobody: a frame is rendered only when one of the image topics has a
subscriber (at the camera rate) or somebody asks for one through the service.

Topics under ``<camera>/`` (relative to the bridge's namespace):

* ``image_raw`` (rgb8), ``labels`` (16UC1): sensor data (best effort), a frame at the scenario's
  ``camera.rate`` while ``publish_camera`` is true and any image topic (these two or the compressed
  ones) has a subscriber.
* ``camera_info``: sensor data, at the camera rate while ``publish_camera`` is true, subscribed to
  or not (it costs no rendering; a bag records the camera model); a frame published carries its stamp.
* ``image_raw/compressed`` (JPEG, ``rgb8; jpeg compressed bgr8``) and ``labels/compressed``
  (lossless PNG, ``16UC1; png compressed ``): sensor_msgs/CompressedImage with
  compressed_image_transport's topic names and format strings, so RViz, Foxglove and
  rqt_image_view (transport "compressed") show them. Encoded only for a topic somebody
  subscribes to, and at most ``compressed_rate`` frames per simulated second (0 = every
  frame); a frame passed by the throttle goes out on both, so image and labels share stamps.
  With only compressed subscribers a frame is rendered only when the throttle passes one, and a
  frame rendered for ``get_frame`` goes out on them too (within the rate): an experiment records
  its camera at a low rate (``compressed_rate``) for few renders of its own.
* ``pose`` and ``label_legend``: latched.

Service ``<camera>/get_frame`` (bridge_interfaces/GetCameraFrame, default services QoS): renders
the current state now and returns image, labels (when asked) and camera_info, stamped with the
simulated time; for consumers that look rarely (the SGCM arms look once per round). It works while
paused; with ``publish_camera`` false (the bridge's camera off, e.g. a camera driver stands in) it
refuses (success false), and such a consumer falls back to the streamed topics.

Parameters (core/settings.py CAMERA_SETTINGS, declared here, all dynamic): ``publish_camera``,
``compressed_rate``, ``jpeg_quality``. The renderer (``camera_renderer``) is the scene's.
"""
from __future__ import annotations

import sys

import numpy as np
from bridge_interfaces.msg import BodyLabel, LabelLegend
from bridge_interfaces.srv import GetCameraFrame
from builtin_interfaces.msg import Time
from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from sensor_msgs.msg import CameraInfo, CompressedImage, Image

from collab_tools.core.image_codec import LABELS_PNG_FORMAT, RGB8_JPEG_FORMAT, encode_labels_png, encode_rgb_jpeg
from collab_tools.input_guard import InputGuard
from collab_tools.parameters import NodeParameters
from collab_tools.qos import LATCHED, SENSOR_OUT

from .core.frames import optical_frame
from .core.scene import Scene
from .core.settings import CAMERA_SETTINGS
from .core.throttle import EPSILON, RateThrottle



def image_msg(array: np.ndarray, encoding: str, stamp: Time, frame_id: str) -> Image:
    array = np.ascontiguousarray(array)
    msg = Image()
    msg.header.stamp = stamp
    msg.header.frame_id = frame_id
    msg.height, msg.width = int(array.shape[0]), int(array.shape[1])
    msg.encoding = encoding
    msg.is_bigendian = int(sys.byteorder == 'big')
    msg.step = int(array.strides[0])
    msg.data = array.tobytes()
    return msg


def compressed_msg(data: bytes, format_text: str, stamp: Time, frame_id: str) -> CompressedImage:
    msg = CompressedImage(format=format_text, data=data)
    msg.header.stamp = stamp
    msg.header.frame_id = frame_id
    return msg


class CameraPublisher:
    """Publishes the scene's camera: frames when due, latched pose and legend on (re)load."""

    def __init__(self, node: Node, params: NodeParameters, camera_ns: str):
        self._node = node
        settings = params.declare_schema(CAMERA_SETTINGS, on_change={
            'publish_camera': self._set_publish_camera, 'compressed_rate': self._set_compressed_rate,
            'jpeg_quality': self._set_jpeg_quality})
        self.publish_camera = settings['publish_camera']
        self.jpeg_quality = settings['jpeg_quality']
        self.throttle = RateThrottle(settings['compressed_rate'])
        self.image_pub = node.create_publisher(Image, f'{camera_ns}/image_raw', SENSOR_OUT)
        self.labels_pub = node.create_publisher(Image, f'{camera_ns}/labels', SENSOR_OUT)
        self.info_pub = node.create_publisher(CameraInfo, f'{camera_ns}/camera_info', SENSOR_OUT)
        # image_transport's names: <base topic>/<transport>.
        self.image_compressed_pub = node.create_publisher(CompressedImage, f'{camera_ns}/image_raw/compressed',
                                                          SENSOR_OUT)
        self.labels_compressed_pub = node.create_publisher(CompressedImage, f'{camera_ns}/labels/compressed',
                                                           SENSOR_OUT)
        self.legend_pub = node.create_publisher(LabelLegend, f'{camera_ns}/label_legend', LATCHED)
        self.pose_pub = node.create_publisher(PoseStamped, f'{camera_ns}/pose', LATCHED)
        self.period = 1.0
        self.next_time = 0.0
        self._scene: Scene | None = None
        self._frame_pubs = (self.image_pub, self.labels_pub, self.image_compressed_pub, self.labels_compressed_pub)
        self.frame_service = InputGuard.of(node).serve(GetCameraFrame, f'{camera_ns}/get_frame', self._on_get_frame)

    # --- parameters ---------------------------------------------------------------------
    def _set_publish_camera(self, value: bool) -> None:
        if value and not self.publish_camera:
            self.next_time = -1.0  # a frame on the next tick
        self.publish_camera = value
        self._node.get_logger().info('camera ' + ('on' if value else 'off'))

    def _set_compressed_rate(self, value: float) -> None:
        self.throttle.set_rate(value)

    def _set_jpeg_quality(self, value: int) -> None:
        self.jpeg_quality = value

    # --- publishing ---------------------------------------------------------------------
    def on_scene_loaded(self, scene: Scene, stamp: Time) -> None:
        """A (new) scene: restart the schedule at its time 0 and publish the latched topics."""
        self._scene = scene
        self.period = 1.0 / scene.scenario.camera.rate
        self.next_time = 0.0
        self.throttle.reset()
        legend = LabelLegend()
        legend.header.stamp = stamp
        legend.header.frame_id = optical_frame(scene.scenario.camera.frame_id)
        legend.entries = [BodyLabel(label=label, name=name, kind=kind) for label, name, kind in scene.label_legend()]
        self.legend_pub.publish(legend)

        position, quaternion = scene.camera.optical_pose()
        pose = PoseStamped()
        pose.header.stamp = stamp
        pose.header.frame_id = scene.scenario.world.frame_id
        pose.pose.position.x, pose.pose.position.y, pose.pose.position.z = map(float, position)
        (pose.pose.orientation.x, pose.pose.orientation.y,
         pose.pose.orientation.z, pose.pose.orientation.w) = map(float, quaternion)
        self.pose_pub.publish(pose)

    def wants_frames(self) -> bool:
        """Whether anybody subscribes to an image topic (raw or compressed)."""
        return any(pub.get_subscription_count() > 0 for pub in self._frame_pubs)

    def _frame_used(self, sim_time: float) -> bool:
        """Whether a frame rendered now reaches anybody: a raw subscriber, or a compressed one while the
        throttle lets a frame through (a recorder of a 2 Hz compressed stream costs 2 renders a second)."""
        if any(pub.get_subscription_count() > 0 for pub in (self.image_pub, self.labels_pub)):
            return True
        compressed = (self.image_compressed_pub, self.labels_compressed_pub)
        return any(pub.get_subscription_count() > 0 for pub in compressed) and self.throttle.due(sim_time)

    def publish_due(self, scene: Scene, stamp: Time) -> None:
        """Publish the camera if due at the scene's time: camera_info always, a frame for subscribers."""
        sim_time = scene.sim_time
        if not self.publish_camera or sim_time + EPSILON < self.next_time:
            return
        self.next_time = sim_time + self.period
        frame_id = optical_frame(scene.scenario.camera.frame_id)
        info = self.camera_info(scene, stamp)
        if not self._frame_used(sim_time):
            self.info_pub.publish(info)
            return
        frame = scene.render()
        self.image_pub.publish(image_msg(frame.rgb, 'rgb8', stamp, frame_id))
        self.labels_pub.publish(image_msg(frame.labels, '16UC1', stamp, frame_id))
        self.info_pub.publish(info)
        self._publish_compressed(frame.rgb, frame.labels, sim_time, stamp, frame_id)

    @staticmethod
    def camera_info(scene: Scene, stamp: Time) -> CameraInfo:
        camera = scene.camera
        info = CameraInfo()
        info.header.stamp = stamp
        info.header.frame_id = optical_frame(scene.scenario.camera.frame_id)
        info.width, info.height = camera.width, camera.height
        info.distortion_model = 'plumb_bob'
        info.d = [0.0] * 5
        info.k = [float(v) for v in camera.intrinsics().flatten()]
        info.r = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
        info.p = [float(v) for v in camera.projection().flatten()]
        return info

    def _on_get_frame(self, request: GetCameraFrame.Request, response: GetCameraFrame.Response):
        scene = self._scene
        if scene is None or not self.publish_camera:
            response.success = False
            response.message = 'no scene loaded yet' if scene is None else 'publish_camera is false: the camera is off'
            return response
        seconds = scene.sim_time
        nanoseconds = int(round(seconds * 1e9))
        stamp = Time(sec=nanoseconds // 1_000_000_000, nanosec=nanoseconds % 1_000_000_000)
        frame_id = optical_frame(scene.scenario.camera.frame_id)
        frame = scene.render()
        response.image = image_msg(frame.rgb, 'rgb8', stamp, frame_id)
        if request.with_labels:
            response.labels = image_msg(frame.labels, '16UC1', stamp, frame_id)
        response.camera_info = self.camera_info(scene, stamp)
        # A frame rendered anyway feeds the compressed stream (a recorder's), within its rate.
        self._publish_compressed(frame.rgb, frame.labels, seconds, stamp, frame_id)
        response.success = True
        response.message = f'frame at {seconds:.3f} s ({scene.renderer.name} renderer)'
        return response

    def _publish_compressed(self, rgb: np.ndarray, labels: np.ndarray, sim_time: float, stamp: Time,
                            frame_id: str) -> None:
        # Nothing is encoded for nobody: a topic without subscribers costs no CPU.
        want_image = self.image_compressed_pub.get_subscription_count() > 0
        want_labels = self.labels_compressed_pub.get_subscription_count() > 0
        if not (want_image or want_labels) or not self.throttle.due(sim_time):
            return
        self.throttle.take(sim_time)
        if want_image:
            self.image_compressed_pub.publish(compressed_msg(encode_rgb_jpeg(rgb, self.jpeg_quality),
                                                             RGB8_JPEG_FORMAT, stamp, frame_id))
        if want_labels:
            self.labels_compressed_pub.publish(compressed_msg(encode_labels_png(labels), LABELS_PNG_FORMAT,
                                                              stamp, frame_id))

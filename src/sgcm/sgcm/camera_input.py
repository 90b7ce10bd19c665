"""The top-view camera as the SGCM nodes see it: labelled frames turned into state estimates.

An arm looks once per round, so by default (``camera_on_demand``, with the raw image transport) it
asks the bridge for a frame
when it needs one, through ``<camera>/get_frame`` (bridge_interfaces/GetCameraFrame: image, labels
and camera_info of the current state), and subscribes only to the latched ``pose`` and
``label_legend``; the bridge then renders nothing between the arms' looks. With
``camera_on_demand: false``, or when the camera refuses requests (the bridge's ``publish_camera``
off) or has no such service (a camera driver that only streams: its ``image_raw`` has a
publisher and no ``get_frame`` appears within :data:`SERVICE_GRACE` seconds), or with
``image_transport: compressed`` (chosen for a node on another host), the frames come from
the streamed topics through the shared :class:`collab_tools.top_camera.TopCamera` (with the label
image and the node's ``image_transport``). Either way this adds which labels are cubes and the
state estimate of :mod:`sgcm.core.perception`. The nodes' ``camera`` and ``image_transport``
parameters are in :mod:`sgcm.core.settings`; ``camera_on_demand`` is declared here
(:data:`CAMERA_INPUT_SETTINGS`).
"""
from __future__ import annotations

import time

import numpy as np
from bridge_interfaces.msg import LabelLegend
from bridge_interfaces.srv import GetCameraFrame
from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from rclpy.time import Time

from collab_tools.core.camera_geometry import TopViewGeometry
from collab_tools.core.settings import Setting, SettingsSchema
from collab_tools.images import image_array
from collab_tools.input_guard import InputGuard
from collab_tools.parameters import NodeParameters
from collab_tools.qos import LATCHED
from collab_tools.top_camera import TopCamera, check_camera_pose

from .core.perception import StateEstimate, estimate_state
from .core.task_config import TaskConfig

CUBE_KIND = 'cube'
#: Wall seconds a streaming camera without a get_frame service is given before the node streams.
SERVICE_GRACE = 3.0
#: Wall seconds a get_frame request may stay unanswered before it is asked again (a crashed camera
#: never answers: without this the node would wait for that answer forever).
REQUEST_TIMEOUT = 10.0

CAMERA_INPUT_SETTINGS = SettingsSchema(
    Setting('camera_on_demand', True, "ask the camera's get_frame service for a frame when one is needed "
            '(once per round) instead of subscribing to its image stream (raw transport only); the stream '
            'is used when the camera refuses or has no such service'),
)


class OnDemandFrames:
    """Frames asked of ``<camera>/get_frame``, one request at a time; the newest answer is kept."""

    def __init__(self, node: Node, ns: str):
        self.node = node
        self.inputs = InputGuard.of(node)
        self.service = f'{ns}/get_frame'
        self.client = node.create_client(GetCameraFrame, self.service)
        self.response: GetCameraFrame.Response | None = None
        self._stamp: Time | None = None     # the response's image stamp, checked
        self.refused: str | None = None     # the camera's reason, once it refuses
        self.requests = 0
        self._pending = None
        self._asked_at = 0.0
        self._geometry: tuple[object, object, TopViewGeometry] | None = None

    def frame_time(self) -> Time | None:
        return None if self.response is None else self._stamp

    def request(self) -> None:
        """Ask for a frame of the current state, unless one is on its way (or the service is not up)."""
        if self._pending is not None and time.monotonic() - self._asked_at < REQUEST_TIMEOUT:
            return
        if not self.client.service_is_ready():
            return
        if self._pending is not None:      # unanswered: the camera that had it is gone
            self.client.remove_pending_request(self._pending)
        self.requests += 1
        self._asked_at = time.monotonic()
        self._pending = pending = self.client.call_async(GetCameraFrame.Request(with_labels=True))
        pending.add_done_callback(lambda future: self._on_response(pending, future))

    def forget(self) -> None:
        """Drop the frame kept (its clock went back: a restarted simulation; its stamp would look new)."""
        self.response = self._stamp = self._geometry = None

    def _on_response(self, pending, future) -> None:
        if pending is not self._pending:
            return                          # a request given up
        self._pending = None
        response = future.result()
        if response is None:
            return
        if not response.success:
            self.refused = response.message or 'refused'
            return
        try:   # an answer with an invalid stamp is no frame (dropped, counted, logged once per kind)
            stamp = self.inputs.stamp(response.image.header.stamp, 'image.header.stamp')
        except ValueError as error:
            self.inputs.reject(self.service, error)
            return
        self.response, self._stamp = response, stamp

    def geometry(self, pose: PoseStamped | None) -> TopViewGeometry:
        if self.response is None or pose is None:
            raise ValueError('no camera frame and pose yet')
        if self._geometry is None or self._geometry[0] is not self.response or self._geometry[1] is not pose:
            p, q = pose.pose.position, pose.pose.orientation
            geometry = TopViewGeometry.from_camera_info(self.response.camera_info.k, (p.x, p.y, p.z),
                                                        (q.x, q.y, q.z, q.w))
            self._geometry = (self.response, pose, geometry)
        return self._geometry[2]


class CameraInput:
    def __init__(self, node: Node, task: TaskConfig, camera: str = '/top_camera', transport: str = 'raw',
                 params: NodeParameters | None = None):
        """camera: absolute namespace (a team-shared sensor); params: the node's, to declare
        camera_on_demand (without them the node streams)."""
        self.node = node
        self.task = task
        self.ns = '/' + camera.strip('/')
        self.transport = transport
        self.camera: TopCamera | None = None       # the stream, once used
        self.frames: OnDemandFrames | None = None
        on_demand = params.declare_schema(CAMERA_INPUT_SETTINGS)['camera_on_demand'] if params else False
        if not on_demand or transport != 'raw':
            self._stream('camera_on_demand is false' if not on_demand else f'image_transport {transport}')
            return
        self.frames = OnDemandFrames(node, self.ns)
        self._pose: PoseStamped | None = None
        self._legend: dict[int, tuple[str, str]] = {}
        inputs = InputGuard.of(node)
        inputs.subscribe(PoseStamped, f'{self.ns}/pose', self._on_pose, LATCHED)
        inputs.subscribe(LabelLegend, f'{self.ns}/label_legend', self._on_legend, LATCHED)
        self._streaming_since: float | None = None   # steady time a stream without service was first seen

    def _on_pose(self, msg: PoseStamped) -> None:
        check_camera_pose(msg)     # a NaN pose must not replace the latched good one
        self._pose = msg

    def _on_legend(self, msg: LabelLegend) -> None:
        self._legend = {entry.label: (entry.name, entry.kind) for entry in msg.entries}

    def _stream(self, reason: str) -> None:
        if self.frames is not None:
            self.node.get_logger().info(f'camera {self.ns}: using the image stream ({reason})')
        self.frames = None
        self.camera = TopCamera(self.node, self.ns, with_labels=True, transport=self.transport)

    def forget_frames(self) -> None:
        """The node's clock went back (a restarted simulation): frames asked for are dropped (a streamed
        camera's newest frame is replaced by the next one anyway)."""
        if self.frames is not None:
            self.frames.forget()

    @property
    def on_demand(self) -> bool:
        return self.frames is not None

    @property
    def legend(self) -> dict[int, tuple[str, str]]:
        return self._legend if self.on_demand else self.camera.legend

    @property
    def cube_labels(self) -> dict[int, str]:
        return {label: name for label, (name, kind) in self.legend.items() if kind == CUBE_KIND}

    def frame_time(self, not_before: Time | None = None) -> Time | None:
        """Stamp of the newest complete frame (RGB + labels with equal stamps).

        On demand, this also asks the camera for a frame when the newest is missing or older than
        ``not_before`` and the node's clock has reached it (the answer comes through the executor:
        call again on the next tick).
        """
        if not self.on_demand:
            return self.camera.frame_time()
        frames = self.frames
        if frames.refused is not None:
            self._stream(f'the camera refused a frame: {frames.refused}')
            return self.camera.frame_time()
        if not frames.client.service_is_ready() and self._stream_without_service():
            self._stream(f'{self.ns}/image_raw has a publisher and no {self.ns}/get_frame service')
            return self.camera.frame_time()
        stamp = frames.frame_time()
        if stamp is None or (not_before is not None and stamp < not_before):
            if not_before is None or self.node.get_clock().now() >= not_before:
                frames.request()
        if stamp is None or self._pose is None or not self._legend:
            return None
        return stamp

    def _stream_without_service(self) -> bool:
        if self.node.count_publishers(f'{self.ns}/image_raw') == 0:
            self._streaming_since = None
            return False
        now = time.monotonic()
        if self._streaming_since is None:
            self._streaming_since = now
        return now - self._streaming_since >= SERVICE_GRACE

    def estimate(self) -> StateEstimate:
        """State estimate from the newest complete frame; ValueError if it cannot be used."""
        ws = self.task.workspace
        top = ws.table_height + ws.cube_size
        if not self.on_demand:
            _, rgb = self.camera.frame()
            return estimate_state(self.camera.labels(), rgb, self.cube_labels, self.camera.geometry(), self.task,
                                  top_height=top)
        response = self.frames.response
        if response is None:
            raise ValueError('no camera frame yet')
        rgb, labels = image_array(response.image), image_array(response.labels)
        return estimate_state(np.asarray(labels), rgb, self.cube_labels, self.frames.geometry(self._pose),
                              self.task, top_height=top)

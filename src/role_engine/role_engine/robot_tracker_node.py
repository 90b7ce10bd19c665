"""robot_tracker: every team robot's pose from the top camera, one small topic per robot (team-level).

``ros2 run role_engine robot_tracker`` runs as ``/robot_tracker`` (or ``-r __ns:=/<team>``) where
the camera's images are: it subscribes to the top camera once (``<team>/<camera>``, sensor-data
QoS), tracks every robot of the team by colour (core.tracking.TeamTracker) and publishes each
robot found on ``<team>/<robot>/tracked_pose`` (geometry_msgs/PoseStamped, stamped with the camera
frame's stamp, in the team's world frame). The role players subscribe to that instead of the
camera, so the image stream crosses the network once.

QoS of the poses: SENSOR_OUT (best effort, volatile). A pose is superseded by the next frame's a
camera period later, so a lost one is not worth re-sending: a retransmitted pose would reach the
controller stale, and a slow or remote subscriber must never hold the tracker back.

The team (names, colours, radii, heights) comes from the role engine's latched
``<team>/roles/team`` (role_interfaces/Team, whose frame_id is the poses' frame): the tracker reads
no file. A robot is published once its heading marker has been seen; while the marker is hidden
its last seen heading is kept.

Its subscriptions go through the node's input guard (collab_tools.input_guard): a malformed team
description or image is dropped, counted and logged once per kind.

Parameters (core.node_settings.TRACKER_SETTINGS): ``camera`` and ``team_namespace`` read-only; the colour matching thresholds
``chroma_tolerance``, ``min_brightness`` and ``min_area_px`` are dynamic (the next frame uses them).
"""
from __future__ import annotations

import sys

from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from role_interfaces.msg import Team

from collab_tools import qos
from collab_tools.core.input_checks import MalformedInput
from collab_tools.input_guard import InputGuard
from collab_tools.names import TeamNode, check_robot_name
from collab_tools.node_support import run
from collab_tools.parameters import NodeParameters
from collab_tools.top_camera import TopCamera

from .core.errors import RoleEngineError
from .core.node_settings import TRACKER_SETTINGS, tracking_settings
from .core.tracking import TeamTracker, TrackedTarget, TrackingSettings
from .role_messages import pose_msg, team_of


class RobotTracker(Node):
    def __init__(self):
        super().__init__('robot_tracker')
        params = NodeParameters(self)
        self.names = TeamNode(self, params)
        dynamic = [s.name for s in TRACKER_SETTINGS if s.dynamic]
        values = params.declare_schema(TRACKER_SETTINGS, on_change={
            name: (lambda value, name=name: self._retune(name, value)) for name in dynamic})
        camera = values['camera']
        self.settings = tracking_settings(values)
        self.tracker: TeamTracker | None = None
        self.frame_id = ''
        self.pose_pubs: dict[str, object] = {}
        InputGuard.of(self).subscribe(Team, self.names.team('roles/team'), self._on_team, qos.LATCHED)
        self.camera = TopCamera(self, self.names.team(camera), on_frame=self._on_frame)
        self.get_logger().info(f"tracking the team of {self.names.team('roles/team')} on {self.names.team(camera)}")

    def _retune(self, name: str, value) -> None:
        settings = TrackingSettings(**{**self.settings.__dict__, name: value})   # RoleEngineError refuses
        self.settings = settings
        if self.tracker is not None:
            self.tracker.settings = settings
        self.get_logger().info(f'{name} set to {value}')

    def _on_team(self, msg: Team) -> None:
        try:
            team = team_of(msg, 0.0)
            bad = [m.name for m in team if check_robot_name(m.name)]
            if bad:
                raise ValueError(f"team: robot names must be ROS name tokens (got {', '.join(bad)})")
            tracker = TeamTracker([TrackedTarget(m.name, m.color, m.robot_type.radius, m.height) for m in team],
                                  self.settings)
        except ValueError as error:     # RoleEngineError too: dropped, counted, logged by the input guard
            raise MalformedInput(f'ignored the team description: {error}', kind='team description') from None
        self.tracker, self.frame_id = tracker, msg.header.frame_id or 'world'
        for member in team:
            if member.name not in self.pose_pubs:
                self.pose_pubs[member.name] = self.create_publisher(
                    PoseStamped, self.names.robot(member.name, 'tracked_pose'), qos.SENSOR_OUT)
        self.get_logger().info(f"tracking {', '.join(m.name for m in team)} (poses in {self.frame_id})")

    def _on_frame(self) -> None:
        if self.tracker is None:
            return
        try:
            stamp, rgb = self.camera.frame()
            poses = self.tracker.update(rgb, self.camera.geometry())
        except (ValueError, RoleEngineError) as error:
            self.get_logger().warn(f'cannot use the camera frame: {error}', throttle_duration_sec=5.0)
            return
        missing = [t.name for t in self.tracker.targets if t.name not in poses]
        if missing:
            self.get_logger().warn(f"no pose (not seen, or heading marker never seen): {', '.join(missing)}",
                                   throttle_duration_sec=5.0)
        for name, pose in poses.items():
            self.pose_pubs[name].publish(pose_msg(pose.x, pose.y, pose.yaw, self.frame_id, stamp.to_msg()))


def main(args=None) -> int:
    return run(RobotTracker, 'robot_tracker', args)


if __name__ == '__main__':
    sys.exit(main())

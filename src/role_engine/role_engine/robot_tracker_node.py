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

Parameters: ``camera`` and ``team_namespace`` read-only; the colour matching thresholds
``chroma_tolerance``, ``min_brightness`` and ``min_area_px`` are dynamic (the next frame uses them).
"""
from __future__ import annotations

import sys

from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from role_interfaces.msg import Team

from collab_tools import qos
from collab_tools.names import TeamNode, check_robot_name
from collab_tools.node_support import run
from collab_tools.parameters import NodeParameters
from collab_tools.top_camera import TopCamera

from .core.errors import RoleEngineError
from .core.tracking import TeamTracker, TrackedTarget, TrackingSettings
from .role_messages import pose_msg, team_of

#: name -> (description, constraints): the dynamic colour matching thresholds.
TRACKING_PARAMETERS: dict[str, tuple[str, dict]] = {
    'chroma_tolerance': ("largest chromaticity distance (rgb / (r + g + b)) of a robot's pixel from its colour; "
                         'from the next frame', {'low': 0.0, 'low_open': True, 'high': 1.0}),
    'min_brightness': ('r + g + b (0..765) below which a pixel is too dark to match a colour (and dark enough '
                       'to be the heading marker); from the next frame', {'low': 0.0, 'high': 765.0}),
    'min_area_px': ('smallest blob (pixels) taken for a robot; from the next frame', {'low': 1}),
}


class RobotTracker(Node):
    def __init__(self):
        super().__init__('robot_tracker')
        params = NodeParameters(self)
        self.names = TeamNode(self, params)
        camera = params.declare('camera', 'top_camera', "the top camera's namespace, relative to the team namespace",
                                check=lambda v: None if v.strip('/') else 'must be a non-empty namespace')
        defaults = TrackingSettings()
        for name, (description, constraints) in TRACKING_PARAMETERS.items():
            params.declare(name, getattr(defaults, name), description,
                           on_change=lambda value, name=name: self._retune(name, value), **constraints)
        self.settings = TrackingSettings(**{name: params[name] for name in TRACKING_PARAMETERS})
        self.tracker: TeamTracker | None = None
        self.frame_id = ''
        self.pose_pubs: dict[str, object] = {}
        self.create_subscription(Team, self.names.team('roles/team'), self._on_team, qos.LATCHED)
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
        except (ValueError, RoleEngineError) as error:
            self.get_logger().error(f'ignored the team description: {error}')
            return
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

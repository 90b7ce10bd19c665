"""MarkerSpec (collab_tools.core.marker_specs) -> visualization_msgs/MarkerArray, one to one."""

import math

from geometry_msgs.msg import Point
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from .core.marker_specs import KINDS, MarkerSpec


def _color(rgba) -> ColorRGBA:
    r, g, b, a = (float(c) for c in rgba)
    return ColorRGBA(r=r, g=g, b=b, a=a)


def marker_msg(spec: MarkerSpec, stamp) -> Marker:
    marker = Marker()
    marker.header.frame_id = spec.frame
    marker.header.stamp = stamp
    marker.ns, marker.id, marker.type, marker.action = spec.ns, int(spec.id), KINDS[spec.kind], Marker.ADD
    marker.pose.position.x, marker.pose.position.y, marker.pose.position.z = (float(v) for v in spec.position)
    marker.pose.orientation.z = math.sin(spec.yaw / 2.0)
    marker.pose.orientation.w = math.cos(spec.yaw / 2.0)
    marker.scale.x, marker.scale.y, marker.scale.z = (float(v) for v in spec.scale)
    marker.color = _color(spec.color)
    marker.points = [Point(x=float(x), y=float(y), z=float(z)) for x, y, z in spec.points]
    marker.colors = [_color(c) for c in spec.colors]
    marker.text = spec.text
    marker.frame_locked = True  # a marker in a robot's frame moves with the robot
    return marker


def marker_array(specs: list[MarkerSpec], stamp) -> MarkerArray:
    """The whole picture: a DELETEALL first, so what a source no longer shows disappears."""
    clear = Marker()
    clear.action = Marker.DELETEALL
    return MarkerArray(markers=[clear] + [marker_msg(spec, stamp) for spec in specs])

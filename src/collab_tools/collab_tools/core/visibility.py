"""One visibility rule for relative-position (fiducial) sensors, shared by every model of it.

The coalition core's geometric sensing (``coalition_agents.core.geometric_sensing``) and the
bridge's simulated fiducial (``pybullet_bridge.core.sensors``) both decide "does this sensor see
that entity" with :func:`in_field_of_view`, so at the exact edge of the field of view or of the
range the core and the simulation give the same answer:

* **Range**: the distance centre to centre is at most ``range_m`` (+ :data:`RANGE_TOLERANCE_M`).
* **Field of view**: the bearing of the target's centre, relative to the heading and wrapped to
  [-pi, pi), is within ``fov / 2`` of the heading, **edges included**, with
  :data:`ANGLE_TOLERANCE_RAD` of slack (it absorbs the round trip of a heading through a
  degree -> radian -> quaternion -> yaw conversion; 1e-6 rad is 4 um at 4 m). A field of view of
  360 deg or more sees every bearing.
* **Line of sight** (:func:`line_of_sight_clear`): the planar segment between the two centres
  meets none of the given obstacle boxes. Boxes are **closed**: a segment that touches a box's
  edge or corner (distance 0) is blocked. The bridge does not use this function: it ray-tests
  pybullet bodies (obstacles, walls, other robots), so it also sees bodies the core is not told
  about. The two agree whenever the line of sight clears every box, or crosses it, by more than
  :data:`GRAZING_TOLERANCE_M`; within that band (a ray grazing a corner) pybullet's answer
  depends on its ray-test numerics and either may come out. Obstacles lower than the sensor
  (the bridge's ray runs at half the robot's height) hide nothing in the bridge: callers pass
  only boxes taller than the sensor (:func:`boxes_above`).

Pure: no simulator, no ROS.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable, Sequence

#: Slack (rad) on the field-of-view edge: a bearing within fov/2 + this is seen.
ANGLE_TOLERANCE_RAD = 1e-6
#: Slack (m) on the range: a target at most range + this away is in range.
RANGE_TOLERANCE_M = 1e-6
#: Below this clearance (m) between a line of sight and a box's boundary the bridge's ray test and
#: :func:`line_of_sight_clear` may disagree (documented, not enforced).
GRAZING_TOLERANCE_M = 1e-3

Point = tuple[float, float]


def wrap_angle(angle: float) -> float:
    """Angle in [-pi, pi)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def bearing(dx: float, dy: float, heading_rad: float) -> float:
    """Bearing (rad, counter-clockwise from the heading, in [-pi, pi)) of the offset (dx, dy)."""
    return wrap_angle(math.atan2(dy, dx) - heading_rad)


def in_field_of_view(dx: float, dy: float, heading_rad: float, fov_deg: float, range_m: float) -> bool:
    """Whether a target at offset (dx, dy) (world frame, from the sensor) is within the range and
    the field of view (centred on ``heading_rad``, edges included; see the module docstring)."""
    if math.hypot(dx, dy) > range_m + RANGE_TOLERANCE_M:
        return False
    if fov_deg >= 360.0:
        return True
    return abs(bearing(dx, dy, heading_rad)) <= math.radians(fov_deg) / 2.0 + ANGLE_TOLERANCE_RAD


@dataclass(frozen=True)
class Box:
    """A planar obstacle: centre (m), full size (m) along its own axes, yaw (rad), height (m)."""

    center: Point
    size: Point
    yaw: float = 0.0
    height: float = math.inf
    name: str = ''

    def corners(self) -> list[Point]:
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        hx, hy = self.size[0] / 2.0, self.size[1] / 2.0
        return [(self.center[0] + c * x - s * y, self.center[1] + s * x + c * y)
                for x, y in ((-hx, -hy), (hx, -hy), (hx, hy), (-hx, hy))]


def segment_meets_box(a: Point, b: Point, box: Box) -> bool:
    """Whether segment a-b touches or crosses the closed box (slab test in the box's frame)."""
    c, s = math.cos(box.yaw), math.sin(box.yaw)

    def local(point: Point) -> Point:
        dx, dy = point[0] - box.center[0], point[1] - box.center[1]
        return c * dx + s * dy, -s * dx + c * dy
    (ax, ay), (bx, by) = local(a), local(b)
    t0, t1 = 0.0, 1.0
    for start, delta, half in ((ax, bx - ax, box.size[0] / 2.0), (ay, by - ay, box.size[1] / 2.0)):
        if delta == 0.0:
            if abs(start) > half:
                return False
            continue
        near, far = (-half - start) / delta, (half - start) / delta
        if near > far:
            near, far = far, near
        t0, t1 = max(t0, near), min(t1, far)
        if t0 > t1:
            return False
    return True


def line_of_sight_clear(segment: tuple[Point, Point], boxes: Iterable[Box]) -> bool:
    """Whether the segment (sensor centre, target centre) meets none of ``boxes`` (closed boxes:
    touching blocks)."""
    a, b = segment
    return not any(segment_meets_box(a, b, box) for box in boxes)


def point_in_box(point: Point, box: Box, margin: float = 0.0) -> bool:
    """Whether ``point`` lies within ``margin`` of the closed box (margin >= 0)."""
    c, s = math.cos(box.yaw), math.sin(box.yaw)
    dx, dy = point[0] - box.center[0], point[1] - box.center[1]
    x, y = abs(c * dx + s * dy) - box.size[0] / 2.0, abs(-s * dx + c * dy) - box.size[1] / 2.0
    return math.hypot(max(x, 0.0), max(y, 0.0)) <= margin


def boxes_above(boxes: Sequence[Box], sensor_height: float) -> list[Box]:
    """The boxes taller than ``sensor_height``: the only ones a sensor at that height cannot see over."""
    return [box for box in boxes if box.height > sensor_height]


def segment_meets_disc(a: Point, b: Point, centre: Point, radius: float) -> bool:
    """Whether segment a-b comes within ``radius`` of ``centre`` (a robot's cylinder seen from above)."""
    dx, dy = b[0] - a[0], b[1] - a[1]
    length2 = dx * dx + dy * dy
    t = 0.0 if length2 == 0.0 else max(0.0, min(1.0, ((centre[0] - a[0]) * dx + (centre[1] - a[1]) * dy) / length2))
    return math.hypot(a[0] + t * dx - centre[0], a[1] + t * dy - centre[1]) <= radius


__all__ = ['ANGLE_TOLERANCE_RAD', 'Box', 'GRAZING_TOLERANCE_M', 'RANGE_TOLERANCE_M', 'bearing', 'boxes_above',
           'in_field_of_view', 'line_of_sight_clear', 'point_in_box', 'segment_meets_box', 'segment_meets_disc',
           'wrap_angle']

"""/tf and /tf_static of the bridge (frames from core/frames.py).

QoS as tf2_ros's broadcasters use it, so tf2 listeners, RViz and Foxglove match:
/tf_static latched (reliable, transient local, depth 1: one message holds every static
transform, re-sent whole when the scene is reloaded), /tf reliable and volatile with a
deep history (tf2_ros's DynamicBroadcasterQoS: depth 100), so a listener that is briefly
slow while a paused bridge is stepped fast still gets every sample.
"""
from __future__ import annotations

from builtin_interfaces.msg import Time
from geometry_msgs.msg import TransformStamped
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from tf2_msgs.msg import TFMessage

from collab_tools.qos import LATCHED

from .core.frames import FrameTransform

TF_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100, reliability=ReliabilityPolicy.RELIABLE,
                    durability=DurabilityPolicy.VOLATILE)


def to_message(transform: FrameTransform, stamp: Time) -> TransformStamped:
    msg = TransformStamped()
    msg.header.stamp = stamp
    msg.header.frame_id = transform.parent
    msg.child_frame_id = transform.child
    t, q = msg.transform.translation, msg.transform.rotation
    t.x, t.y, t.z = (float(v) for v in transform.pose.translation)
    q.x, q.y, q.z, q.w = (float(v) for v in transform.pose.rotation)
    return msg


class TfPublisher:
    """Publishes the scene's frames; /tf and /tf_static stay absolute (remapped per session)."""

    def __init__(self, node: Node):
        self.static_pub = node.create_publisher(TFMessage, '/tf_static', LATCHED)
        self.dynamic_pub = node.create_publisher(TFMessage, '/tf', TF_QOS)

    def publish_static(self, transforms: list[FrameTransform], stamp: Time) -> None:
        self.static_pub.publish(TFMessage(transforms=[to_message(t, stamp) for t in transforms]))

    def publish(self, transforms: list[FrameTransform], stamp: Time) -> None:
        if transforms:
            self.dynamic_pub.publish(TFMessage(transforms=[to_message(t, stamp) for t in transforms]))

"""ROS faces of scene entities.

Each entity kind that talks to ROS (subscribes to commands, publishes sensor data,
serves actions) has an adapter class registered here. The bridge creates one adapter
per entity after every (re)load and calls it each tick, so a new kind (arms, cubes,
sensors) is added with a core entity plus an adapter, without editing the main loop.
"""

import math
from collections.abc import Callable

from geometry_msgs.msg import Twist
from rclpy.client import Client
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.service import Service
from rclpy.subscription import Subscription
from rclpy.timer import Timer

from collab_tools.core.input_checks import MalformedInput
from collab_tools.input_guard import InputGuard
from collab_tools.qos import SENSOR_IN

from .core.mobile_robot import MobileRobot
from .core.entity import SceneEntity

# Reports a dropped input: (source, reason). The bridge logs and counts it.
RejectFn = Callable[[str, str], None]


class EntityAdapter:
    """Base class: holds the entity and the ROS objects created for it."""

    def __init__(self, node: Node, entity: SceneEntity, reject: RejectFn):
        self.node = node
        self.entity = entity
        self.reject = reject
        self._ros_objects = []

    def on_tick(self, sim_time: float) -> None:
        """Called after every control tick of the simulation."""

    def on_rate_change(self, sim_time: float) -> None:
        """Called when the node's ground_truth_rate changed (parameter set at run time)."""

    def destroy(self, node_closing: bool = False) -> None:
        """Destroy the adapter's ROS objects: before a scene reset, or with ``node_closing`` when the
        node goes (its context may be shut down already: create nothing then)."""
        # Through the node, not obj.destroy(): the node must also drop them (and their
        # QoS event handlers) from its wait set, or the executor hits dead handles.
        destroyers = {Subscription: self.node.destroy_subscription,
                      Publisher: self.node.destroy_publisher,
                      Service: self.node.destroy_service,
                      Client: self.node.destroy_client,
                      Timer: self.node.destroy_timer}
        for obj in self._ros_objects:
            for ros_type, destroy in destroyers.items():
                if isinstance(obj, ros_type):
                    destroy(obj)
                    break
            else:
                obj.destroy()  # e.g. action servers own their destroy()
        self._ros_objects.clear()


_ADAPTERS: dict[type, type[EntityAdapter]] = {}


def register_adapter(entity_type: type, adapter_type: type[EntityAdapter]) -> None:
    _ADAPTERS[entity_type] = adapter_type


def create_adapters(node: Node, entities, reject: RejectFn) -> list[EntityAdapter]:
    adapters = []
    for entity in entities:
        for entity_type in type(entity).__mro__:
            if entity_type in _ADAPTERS:
                adapters.append(_ADAPTERS[entity_type](node, entity, reject))
                break
    return adapters


class MobileRobotAdapter(EntityAdapter):
    """<robot>/cmd_vel (geometry_msgs/Twist, relative to the node's namespace) -> drive command.

    Subscribed best effort (SENSOR_IN), so a best-effort teleop is heard as well as a reliable one,
    through the node's input guard: a non-finite or refused command is dropped, counted (the
    bridge's status ``rejected_messages``) and logged once per kind.
    """

    def __init__(self, node: Node, entity: MobileRobot, reject: RejectFn):
        super().__init__(node, entity, reject)
        self.topic = f'{entity.name}/cmd_vel'
        self._ros_objects.append(
            InputGuard.of(node).subscribe(Twist, self.topic, self._on_cmd_vel, SENSOR_IN))

    def _on_cmd_vel(self, msg: Twist) -> None:
        values = (msg.linear.x, msg.angular.z)
        if not all(math.isfinite(v) for v in values):
            raise MalformedInput(f'non-finite velocity (linear.x={values[0]}, angular.z={values[1]}); keeping '
                                 'the previous command', kind='non-finite velocity')
        ignored = [name for name, value in (('linear.y', msg.linear.y), ('linear.z', msg.linear.z),
                                            ('angular.x', msg.angular.x),
                                            ('angular.y', msg.angular.y))
                   if value != 0.0]
        if ignored:
            # A differential drive cannot follow these; say so rather than drop them silently.
            self.node.get_logger().warn(
                f'{self.topic}: ignoring {", ".join(ignored)} (differential drive uses '
                'linear.x and angular.z only)', throttle_duration_sec=5.0)
        self.entity.set_command(values[0], values[1], self.node.scene.sim_time)   # ValueError: dropped


register_adapter(MobileRobot, MobileRobotAdapter)

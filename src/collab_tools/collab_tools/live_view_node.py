"""live_view node: the run's ROS topics live in the Foxglove app, through foxglove-sdk's WebSocket server.

Every topic the node discovers (``topics``/``exclude``, as the bag recorder selects them) is
advertised on a channel with its ``ros2msg`` schema (as the recorder writes it) and ``cdr`` message
encoding; while a Foxglove client subscribes to a channel, the node subscribes to the topic raw (the
serialized CDR is forwarded untouched) with a QoS every publisher matches (best effort where a
publisher is: sensor topics), latched where every publisher is. The behaviour lives in
:mod:`collab_tools.core.live_view`. Connect: Foxglove app -> Open connection -> ws://127.0.0.1:8765.
"""

import logging
import sys

import foxglove
from foxglove.websocket import Capability
from rclpy.clock import Clock, ClockType
from rclpy.node import Node

from . import qos
from .bag_recorder_node import subscription_qos
from .core.live_view import (LIVE_VIEW_SETTINGS, MESSAGE_ENCODING, SCHEMA_ENCODING, LiveChannels, SchemaBook,
                             TopicSelection, connect_hint)
from .input_guard import InputGuard
from .node_support import ConfigurationError, run
from .parameters import NodeParameters
from .ros_interfaces import import_interface
from .topic_discovery import DiscoveryTimer, topic_names_problem

#: Wall seconds between the simulated times sent to the app.
TIME_PERIOD = 0.2
#: What the SDK's reports about clients are logged as arriving on.
WEBSOCKET = 'websocket'


class _Listener:
    """The server's callbacks (its own thread): record the change, wake the executor."""

    def __init__(self, channels: LiveChannels, wake):
        self.channels, self.wake = channels, wake

    def on_subscribe(self, client, channel) -> None:
        self.channels.client_subscribed(client.id, channel.id)
        self.wake()

    def on_unsubscribe(self, client, channel) -> None:
        self.channels.client_unsubscribed(client.id, channel.id)
        self.wake()


class _ClientErrors(logging.Handler):
    """The SDK's warnings and errors (a client's invalid frames, a subscription to an unknown channel; its
    own thread) through the node's input guard: the first of each kind logged, the rest counted, so a
    client sending garbage cannot flood the log."""

    def __init__(self, inputs: InputGuard):
        super().__init__(logging.WARNING)
        self.inputs = inputs

    def emit(self, record: logging.LogRecord) -> None:
        self.inputs.reject(WEBSOCKET, ValueError(record.getMessage()))


class LiveView(Node):

    def __init__(self):
        super().__init__('live_view')
        self.params = NodeParameters(self)
        schema = LIVE_VIEW_SETTINGS.replaced('topics', check=lambda topics: topic_names_problem(self, topics))
        values = self.params.declare_schema(schema, on_change={'discovery_period': lambda p: self.discovery.set_period(p)})
        self.selection = TopicSelection(tuple(self.resolve_topic_name(t) for t in values['topics'] if t),
                                        tuple(values['exclude']))
        self.queue_depth = values['queue_depth']
        self.channels = LiveChannels()
        self.schemas = SchemaBook()
        self.subscriptions_by_topic = {}
        self.sim_time = self.get_parameter('use_sim_time').value
        self.wake = self.create_guard_condition(self._apply_client_changes)
        self.foxglove_context = foxglove.Context()
        sdk_log = logging.getLogger('foxglove')  # the SDK logs through Python's logging (lastResort otherwise)
        sdk_log.addHandler(_ClientErrors(InputGuard.of(self)))
        sdk_log.propagate = False
        try:
            self.server = foxglove.start_server(
                name=values['server_name'], host=values['host'], port=values['port'], context=self.foxglove_context,
                server_listener=_Listener(self.channels, self.wake.trigger), supported_encodings=[MESSAGE_ENCODING],
                capabilities=[Capability.Time] if self.sim_time else [])
        except Exception as error:  # the SDK's error when the address is taken or cannot be bound
            raise ConfigurationError(f'parameter host/port: cannot serve on {values["host"]}:{values["port"]} '
                                     f'({error})') from None
        self.port = self.server.port
        self.get_logger().info(f'Foxglove WebSocket server on {values["host"]}:{self.port}; '
                               + connect_hint(values['host'], self.port))
        self.discovery = DiscoveryTimer(self, self._discover, values['discovery_period'])
        if self.sim_time:  # the app's clock follows the simulation (the Time capability)
            self.create_timer(TIME_PERIOD, lambda: self.server.broadcast_time(self.get_clock().now().nanoseconds),
                              clock=Clock(clock_type=ClockType.STEADY_TIME))
        self._discover()

    # --- topics -> channels --------------------------------------------------------------------------
    def _discover(self) -> None:
        present = set()
        for topic, type_names in self.get_topic_names_and_types():
            if not self.selection.wanted(topic) or topic in self.channels.failures:
                continue
            if not self.get_publishers_info_by_topic(topic):
                continue  # only subscribers so far (or no more publishers)
            present.add(topic)
            if self.channels.advertised(topic) is None:
                self._advertise(topic, type_names)
        for entry in self.channels.vanished(present):
            self._drop_subscription(entry)
            self.channels.remove(entry.topic)
            entry.channel.close()
            self.get_logger().info(f'{entry.topic}: no publisher any more, channel closed')

    def _advertise(self, topic: str, type_names: list[str]) -> None:
        try:
            if len(type_names) != 1:
                raise ValueError(f'it carries several types {type_names}')
            import_interface(type_names[0])  # the raw subscription needs the type support
            schema_name, definition = self.schemas.schema(type_names[0])
        except Exception as error:  # whatever it is, the topic cannot be shown: say so once
            self.channels.failures[topic] = str(error)
            self.get_logger().warn(f'{topic}: not forwarded: {error}')
            return
        channel = foxglove.Channel(topic, message_encoding=MESSAGE_ENCODING, context=self.foxglove_context,
                                   schema=foxglove.Schema(name=schema_name, encoding=SCHEMA_ENCODING, data=definition))
        self.channels.add(topic, type_names[0], channel, channel.id())
        self.get_logger().info(f'advertised {topic} [{schema_name}]')

    # --- client subscriptions -> ROS subscriptions ------------------------------------------------------
    def _apply_client_changes(self) -> None:
        for change, entry in self.channels.pending():
            if change == 'subscribe':
                self._subscribe(entry)
            else:
                self._drop_subscription(entry)

    def _subscribe(self, entry) -> None:
        offered = [info.qos_profile for info in self.get_publishers_info_by_topic(entry.topic)]
        profile = subscription_qos(offered, self.queue_depth) if offered else qos.SENSOR_IN
        self.subscriptions_by_topic[entry.topic] = self.create_subscription(
            import_interface(entry.type_name), entry.topic, self._forwarder(entry.channel), profile, raw=True)
        entry.subscribed = True
        self.get_logger().info(f'forwarding {entry.topic} ({profile.reliability.name.lower()}, '
                               f'{profile.durability.name.lower()})')

    def _forwarder(self, channel):
        def forward(data: bytes) -> None:  # one argument: rclpy passes no message info then
            channel.log(data, log_time=self.get_clock().now().nanoseconds)
        return forward

    def _drop_subscription(self, entry) -> None:
        subscription = self.subscriptions_by_topic.pop(entry.topic, None)
        if subscription is not None:
            self.destroy_subscription(subscription)
            self.get_logger().info(f'stopped forwarding {entry.topic} (no client watches it)')
        entry.subscribed = False

    def destroy_node(self):
        server = getattr(self, 'server', None)
        if server is not None:
            server.stop()
        super().destroy_node()


def main(args=None) -> int:
    return run(LiveView, 'live_view', args)


if __name__ == '__main__':
    sys.exit(main())

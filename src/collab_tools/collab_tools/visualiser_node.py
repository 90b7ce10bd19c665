"""visualiser node: the subsystems' messages as visualization_msgs/MarkerArray, for Foxglove and RViz.

One node for all subsystems: each subsystem's core has a *marker source* (its inputs and a pure
builder from its messages to :class:`~collab_tools.core.marker_specs.MarkerSpec`); the node loads the
sources named in ``sources`` (``collab_tools.core.marker_specs.MARKER_SOURCES``), subscribes to
their inputs through the InputGuard (a malformed message is dropped, counted, logged) and publishes
each source's picture on ``markers/<source>`` (latched, relative to its namespace) in the frames
the TF tree has. Why one node in collab_tools: the sources are plain data in each package's
core, imported only when asked for, so packages keep depending on collab_tools and not the
reverse, and a run needs one extra process, not three.
"""

import dataclasses
import importlib
import sys

from rclpy.clock import Clock, ClockType
from rcl_interfaces.srv import GetParameters
from rclpy.node import Node
from visualization_msgs.msg import MarkerArray

from . import qos
from .core.marker_specs import MARKER_SOURCES
from .core.settings import Setting, SettingsSchema
from .input_guard import InputGuard
from .markers_ros import marker_array
from .node_support import ConfigurationError, run
from .parameters import NodeParameters
from .ros_interfaces import import_interface

QOS = {'latched': qos.LATCHED, 'reliable': qos.RELIABLE, 'sensor': qos.SENSOR_IN}

VISUALISER_SETTINGS = SettingsSchema(
    Setting('sources', list(MARKER_SOURCES), 'marker sources to run, each published on markers/<source>',
            choices=tuple(MARKER_SOURCES)),
    Setting('world_frame', 'world', 'the TF root frame the markers of world positions are in'),
    Setting('rate', 2.0, 'Hz (wall clock) at which pictures that change with time (current process roles) are '
            'published again', low=0.1, high=50.0),
    Setting('discovery_period', 1.0, 'seconds (wall clock) between looks for per-robot input topics',
            low=0.05, high=60.0),
)


def load_source(name: str):
    module_name, _, class_name = MARKER_SOURCES[name].partition(':')
    try:
        return getattr(importlib.import_module(module_name), class_name)
    except (ImportError, AttributeError) as error:
        raise ConfigurationError(f'parameter sources: {name}: cannot load {MARKER_SOURCES[name]} ({error}); '
                                 'is its package built and sourced?') from None


class Visualiser(Node):

    def __init__(self):
        super().__init__('visualiser')
        self.params = NodeParameters(self)
        values = self.params.declare_schema(VISUALISER_SETTINGS)
        self.inputs = InputGuard.of(self)
        self.sources, self.publishers_by_source, self.found = {}, {}, set()
        self.parameter_requests = {}
        for name in dict.fromkeys(values['sources']):
            source_class = load_source(name)
            settings = {s.name: self.params.declare_setting(dataclasses.replace(s, name=f'{name}.{s.name}'))
                        for s in getattr(source_class, 'SETTINGS', ())}
            source = source_class(world_frame=values['world_frame'], **settings)
            self.sources[name] = source
            self.publishers_by_source[name] = self.create_publisher(MarkerArray, f'markers/{name}', qos.LATCHED)
            for marker_input in source_class.INPUTS:
                if marker_input.topic is not None:
                    self._subscribe(name, marker_input, marker_input.topic)
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.create_timer(1.0 / values['rate'], self._publish_timed, clock=steady)
        self.create_timer(values['discovery_period'], self._discover, clock=steady)
        self.create_timer(0.5, self._send_parameter_requests, clock=steady)
        self.get_logger().info(f'publishing {", ".join("markers/" + n for n in self.sources)} '
                               f'(frame {values["world_frame"]})')
        self._discover()

    def _subscribe(self, name: str, marker_input, topic: str) -> None:
        handler = getattr(self.sources[name], marker_input.handler)
        resolved = self.resolve_topic_name(topic)
        self.found.add((name, resolved))

        def on_message(msg):
            self._ask_publisher(name, marker_input, resolved)
            handler(msg, resolved)
            if marker_input.redraw:
                self._publish(name)
        try:
            msg_type = import_interface(marker_input.type_name)
        except ValueError as error:  # the source's message package is not installed
            raise ConfigurationError(f'parameter sources: {name}: {error}') from None
        self.inputs.subscribe(msg_type, topic, on_message, QOS[marker_input.qos])

    def _discover(self) -> None:
        """Subscribe to every topic of the type-matched inputs in this node's namespace."""
        prefix = self.get_namespace().rstrip('/') + '/'
        topics = self.get_topic_names_and_types()
        for name, source in self.sources.items():
            for marker_input in source.INPUTS:
                if marker_input.topic is not None:
                    continue
                for topic, types in topics:
                    if topic.startswith(prefix) and marker_input.type_name in types \
                            and (name, topic) not in self.found:
                        self._subscribe(name, marker_input, topic)

    def _ask_publisher(self, name: str, marker_input, topic: str) -> None:
        """Read a parameter the source needs from the node publishing ``topic`` (once it has one)."""
        wanted = marker_input.publisher_parameter
        key = (name, wanted)
        if wanted is None or key in self.parameter_requests or not self.sources[name].wants_parameter(wanted):
            return
        publishers = self.get_publishers_info_by_topic(topic)
        if publishers:
            info = publishers[0]
            remote = info.node_namespace.rstrip('/') + '/' + info.node_name
            client = self.create_client(GetParameters, f'{remote}/get_parameters')
            self.parameter_requests[key] = (remote, client, None)
            self._send_parameter_requests()

    def _send_parameter_requests(self) -> None:
        """Send each parameter request once its service is discovered (a request before would be lost)."""
        for (name, wanted), (remote, client, future) in list(self.parameter_requests.items()):
            if future is None and client.service_is_ready():
                future = client.call_async(GetParameters.Request(names=[wanted]))
                future.add_done_callback(lambda f, n=name, w=wanted, r=remote: self._parameter_answer(n, w, r, f))
                self.parameter_requests[(name, wanted)] = (remote, client, future)

    def _parameter_answer(self, name: str, wanted: str, remote: str, future) -> None:
        try:
            value = future.result().values[0].string_value
            self.sources[name].set_parameter(wanted, value)
            self.get_logger().info(f'{name}: {wanted} = {value!r} (from {remote})')
            self._publish(name)
        except Exception as error:  # no such parameter, a value the source refuses: said once, not retried
            self.get_logger().warning(f'{name}: cannot use {wanted} of {remote}: {error}')

    def _publish(self, name: str) -> None:
        now = self.get_clock().now()
        try:
            specs = self.sources[name].markers(now.nanoseconds / 1e9)
        except (ValueError, TypeError, KeyError, IndexError, ArithmeticError) as error:
            self.inputs.reject(f'markers/{name}', error)
            return
        if specs is not None:
            self.publishers_by_source[name].publish(marker_array(specs, now.to_msg()))

    def _publish_timed(self) -> None:
        for name, source in self.sources.items():
            if getattr(source, 'time_dependent', False):
                self._publish(name)


def main(args=None) -> int:
    return run(Visualiser, 'visualiser', args)


if __name__ == '__main__':
    sys.exit(main())

"""The orchestrator's own view of the ROS graph: wait for messages, services, calls.

Runs an rclpy node in a private context (so it never clashes with a test's or a
script's own rclpy use) in the session's domain, spun by a background thread.
"""

import threading
import time
from collections.abc import Callable
from typing import Any

import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import NodeNameNonExistentError
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions

from ..ros_interfaces import import_interface

POLL_PERIOD_S = 0.05


class ConditionTimeout(TimeoutError):
    pass


class GraphObserver:

    def __init__(self, domain_id: int, node_name: str = 'orchestrator', enclave: str | None = None):
        self.context = Context()
        # enclave: its SROS2 identity when the session is secured (orchestration.security).
        rclpy.init(context=self.context, domain_id=domain_id, signal_handler_options=SignalHandlerOptions.NO,
                   args=['--ros-args', '--enclave', enclave] if enclave else None)
        self.node = rclpy.create_node(node_name, context=self.context,
                                      start_parameter_services=False)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._spin, name='graph-observer', daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        while not self._stop.is_set() and self.context.ok():
            self.executor.spin_once(timeout_sec=POLL_PERIOD_S)

    def _wait(self, done: Callable[[], bool], timeout: float, what: str,
              check: Callable[[], None] | None) -> None:
        deadline = time.monotonic() + timeout
        while not done():
            if check is not None:
                check()
            if time.monotonic() > deadline:
                raise ConditionTimeout(f'timed out after {timeout:.1f} s waiting for {what}')
            time.sleep(POLL_PERIOD_S)

    def wait_for_message(self, topic: str, type_name: str,
                         predicate: Callable[[Any], bool] | None = None,
                         timeout: float = 30.0, latched: bool = False,
                         check: Callable[[], None] | None = None) -> Any:
        """First message on `topic` for which predicate(msg) holds."""
        msg_type = import_interface(type_name)
        matched: list[Any] = []

        def on_message(msg):
            if not matched and (predicate is None or predicate(msg)):
                matched.append(msg)

        # Latched: the last sample from a transient-local publisher. Otherwise best effort, which
        # matches reliable and best-effort (sensor-data) publishers alike.
        qos = (QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE,
                          durability=DurabilityPolicy.TRANSIENT_LOCAL) if latched
               else QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT,
                               durability=DurabilityPolicy.VOLATILE))
        subscription = self.node.create_subscription(msg_type, topic, on_message, qos)
        try:
            self._wait(lambda: bool(matched), timeout, f'a matching message on {topic}', check)
        finally:
            self.node.destroy_subscription(subscription)
        return matched[0]

    def follow(self, topic: str, type_name: str, on_message: Callable[[Any], None], latched: bool = False) -> None:
        """Call ``on_message(msg)`` for every message on ``topic`` until the observer closes (the run's
        progress lines); an exception in ``on_message`` is the caller's to catch, never the spin thread's."""
        qos = (QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE,
                          durability=DurabilityPolicy.TRANSIENT_LOCAL) if latched
               else QoSProfile(depth=50, reliability=ReliabilityPolicy.BEST_EFFORT,
                               durability=DurabilityPolicy.VOLATILE))
        self.node.create_subscription(import_interface(type_name), topic, on_message, qos)

    def call_service(self, service: str, type_name: str, request: Any | None = None,
                     timeout: float = 30.0, check: Callable[[], None] | None = None) -> Any:
        srv_type = import_interface(type_name)
        client = self.node.create_client(srv_type, service)
        try:
            self._wait(lambda: client.service_is_ready(), timeout,
                       f'service {service} to appear', check)
            future = client.call_async(request if request is not None else srv_type.Request())
            self._wait(future.done, timeout, f'the response of {service}', check)
            return future.result()
        finally:
            self.node.destroy_client(client)

    def node_names(self) -> set[str]:
        """Full names (/namespace/name) of the nodes in the graph now."""
        return {(ns.rstrip('/') + '/' + name) for name, ns in self.node.get_node_names_and_namespaces()}

    def endpoints(self, full_name: str) -> tuple[list[str], ...]:
        """Names of what node ``full_name`` (/namespace/name) publishes, subscribes, serves and calls
        now (empty when it is not in the graph): what its SROS2 permissions must allow."""
        namespace, _, name = full_name.rpartition('/')
        queries = (self.node.get_publisher_names_and_types_by_node, self.node.get_subscriber_names_and_types_by_node,
                   self.node.get_service_names_and_types_by_node, self.node.get_client_names_and_types_by_node)
        try:
            return tuple([topic for topic, _types in query(name, namespace or '/')] for query in queries)
        except NodeNameNonExistentError:
            return ([], [], [], [])

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=2.0)
        self.executor.shutdown()
        self.node.destroy_node()
        self.context.try_shutdown()

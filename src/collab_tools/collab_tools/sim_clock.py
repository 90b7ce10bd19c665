"""A node's simulated clock follows only valid /clock messages.

With ``use_sim_time`` true, rclpy's ``TimeSource`` subscribes to ``/clock`` itself and turns every
message into ``rclpy.time.Time``: one message with a negative ``sec`` raised ``ValueError`` in
that callback and ended every node on simulated time (and the recorder left an unreadable bag).
:func:`guard_sim_clock` puts :class:`~collab_tools.core.input_checks.ClockFilter` in front of the
time source's callback: a refused message is dropped, counted and logged once per kind by the
node's :class:`~collab_tools.input_guard.InputGuard`; a valid one goes on to rclpy's own callback,
which sets the ROS time override of the node's clocks as before.

``use_sim_time`` keeps its standard meaning: it is still rclpy's parameter, set at start or with
``ros2 param set`` (applied by the time source, which now subscribes through the guarded
callback; a non-bool is refused by rclpy). :class:`collab_tools.parameters.NodeParameters` calls
:func:`guard_sim_clock` for every node it is made for, so every node of the workspace (and the
nodes an agent host composes) is covered without a line of its own.
"""
from __future__ import annotations

from rclpy.node import Node
from rclpy.time_source import CLOCK_TOPIC, TimeSource

from .core.input_checks import ClockFilter, MalformedInput
from .input_guard import InputGuard

_GUARDED = '_collab_clock_filter'


def guard_sim_clock(node: Node) -> ClockFilter | None:
    """Validate the node's /clock before its time source uses it (idempotent). The filter, or None when
    this rclpy keeps its time source elsewhere (logged: the node then runs unguarded)."""
    # rclpy has no public accessor for a node's time source: Node.__init__ keeps it here.
    source = getattr(node, '_time_source', None)
    if not isinstance(source, TimeSource):
        node.get_logger().warning('cannot guard /clock: this rclpy keeps no Node._time_source; '
                                  'a malformed /clock message can still end this node')
        return None
    existing = getattr(source, _GUARDED, None)
    if existing is not None:
        return existing
    inputs = InputGuard.of(node)
    clock_filter = ClockFilter()
    use = source.clock_callback          # rclpy's own: caches the time and sets every attached clock

    def clock_callback(msg) -> None:
        try:
            clock_filter.accept(msg.clock.sec, msg.clock.nanosec)
        except MalformedInput as error:
            inputs.reject(CLOCK_TOPIC, error)
            return
        use(msg)

    # TimeSource._subscribe_to_clock_topic subscribes with self.clock_callback, looked up when it
    # subscribes: from now on that is the guarded one.
    source.clock_callback = clock_callback
    setattr(source, _GUARDED, clock_filter)
    if source.ros_time_is_active:
        # use_sim_time was true at start: the subscription exists with rclpy's callback. Off and on
        # again (the time source's public switch) subscribes anew, through the guard; the clocks
        # keep their ROS time override meanwhile.
        source.ros_time_is_active = False
        source.ros_time_is_active = True
    return clock_filter

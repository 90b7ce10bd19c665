"""An arm's ``pick_and_place`` action as the SGCM nodes use it: one goal at a time, given up when the
bridge is gone (sgcm.core.arm_goal.GoalWatch: a timeout and server loss, on the steady clock).

``send(goal, done)`` calls ``done(success, message)`` exactly once: with the action's result, when
the arm refuses the goal, or when the goal is given up (the goal is then cancelled, in case the
server still runs it; also when a new instance of the server appears), or at once when the node's
clock goes back (:meth:`abandon`: a restarted
simulation, whose new action server may be in the graph before the old one has left it). The
bounds are the nodes' parameters ``arm_goal_timeout`` and ``arm_server_lost_after``
(:data:`ARM_SETTINGS`; dynamic: applied to the goal out, too).
"""
from __future__ import annotations

import time
from collections.abc import Callable

from bridge_interfaces.action import PickAndPlace
from rclpy.action import ActionClient
from rclpy.clock import Clock, ClockType
from rclpy.node import Node

from collab_tools.core.settings import Setting, SettingsSchema
from collab_tools.parameters import NodeParameters

from .core.arm_goal import GOAL_TIMEOUT, SERVER_LOST_AFTER, GoalWatch

ARM_SETTINGS = SettingsSchema(
    Setting('arm_goal_timeout', GOAL_TIMEOUT, 'wall seconds (steady clock) a pick_and_place goal may take before '
            'it is given up and the move counts as not done (applied to the goal out too)', low=1.0, high=3600.0,
            dynamic=True),
    Setting('arm_server_lost_after', SERVER_LOST_AFTER, "wall seconds the arm's action server may be missing from "
            'the graph while a goal is out (a crashed bridge) before the goal is given up', low=0.5, high=600.0,
            dynamic=True),
)
#: s (steady) between checks of the goal out.
CHECK_PERIOD = 0.5
#: ns: the nodes' clock going back by more than this is a restarted (or reset) simulation.
CLOCK_BACK_NS = 500_000_000

Done = Callable[[bool, str], None]


class ArmClient:
    def __init__(self, node: Node, params: NodeParameters, name: str = 'pick_and_place'):
        self.node = node
        self.action = ActionClient(node, PickAndPlace, name)
        self._status = node.resolve_topic_name(f'{name}/_action/status')
        values = params.declare_schema(ARM_SETTINGS, on_change={
            'arm_goal_timeout': self._set_timeout, 'arm_server_lost_after': self._set_lost_after})
        self.watch = GoalWatch(values['arm_goal_timeout'], values['arm_server_lost_after'])
        self._done: Done | None = None
        self._handle = None
        # Steady: a crashed bridge stops /clock, and a timer on simulated time with it.
        node.create_timer(CHECK_PERIOD, self._check, clock=Clock(clock_type=ClockType.STEADY_TIME))

    def _set_timeout(self, value: float) -> None:
        self.watch.timeout = float(value)

    def _set_lost_after(self, value: float) -> None:
        self.watch.server_lost_after = float(value)

    def server_is_ready(self) -> bool:
        return self.action.server_is_ready()

    def server_endpoints(self) -> frozenset:
        """The graph's endpoints (gids) publishing the action's status: one per action server instance."""
        return frozenset(bytes(info.endpoint_gid) for info in self.node.get_publishers_info_by_topic(self._status))

    def send(self, goal: PickAndPlace.Goal, done: Done) -> None:
        token = self.watch.sent(time.monotonic(), self.server_endpoints())
        self._done, self._handle = done, None
        self.action.send_goal_async(goal).add_done_callback(lambda future: self._on_response(token, future))

    def _on_response(self, token: int, future) -> None:
        handle = future.result()
        if handle is None or not handle.accepted:
            self._finish(token, False, 'the arm rejected the move')
            return
        if self.watch.busy and self._handle is None:
            self._handle = handle
        handle.get_result_async().add_done_callback(lambda f: self._on_result(token, f))

    def _on_result(self, token: int, future) -> None:
        response = future.result()
        if response is None:
            self._finish(token, False, 'no result from the arm')
            return
        self._finish(token, bool(response.result.success), response.result.message)

    def _finish(self, token: int, success: bool, message: str) -> None:
        if not self.watch.finished(token):
            return                      # a goal given up: its late answer changes nothing
        done, self._done, self._handle = self._done, None, None
        done(success, message)

    def abandon(self, reason: str) -> None:
        """Give the goal out up now (the simulation restarted: no server will finish a goal of the old one)."""
        if self.watch.give_up():
            self._give_up(reason)

    def _check(self) -> None:
        if not self.watch.busy:
            return
        reason = self.watch.check(time.monotonic(), self.action.server_is_ready(), self.server_endpoints())
        if reason is not None:
            self._give_up(reason)

    def _give_up(self, reason: str) -> None:
        handle, done, self._done, self._handle = self._handle, self._done, None, None
        if handle is not None:
            handle.cancel_goal_async()  # the server may still run it (a timeout, not a crash)
        self.node.get_logger().error(f'pick_and_place goal given up: {reason}; the move counts as not done')
        done(False, f'given up: {reason}')

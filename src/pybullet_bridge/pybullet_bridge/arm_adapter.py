"""ROS face of the arms: the <arm>/pick_and_place action and <arm>/joint_states.

Both names are relative to the node's namespace; joint states are sensor data (best effort).

Goals are always accepted at goal time and judged by the core when they start: a bad
goal (unknown object, malformed region, out of reach, arm busy) ends at once with
outcome REJECTED and a message saying why, which a client reads from the result (a
goal-time rejection could not carry a reason). The execute callback is a coroutine that
awaits a future resolved from ``on_tick``, so the single-threaded executor that steps
the simulation is never blocked. Feedback (phase, progress) is published when the
phase changes or progress has grown by 5 %.

A cancel is accepted while the core can still undo the move (before the object is
released); the goal then ends CANCELED with outcome ABORTED once the arm is home.

Scene resets: the bridge destroys every adapter and creates new ones. The action
server of an arm is kept per node and arm name (:class:`_PickAndPlaceServer`) and
handed from the old adapter to the new one, so a goal that was running finishes with
ABORTED through the ordinary result path, and clients stay connected. A server whose
arm is gone from the new scene is destroyed once no goal of it is in flight.

Node shutdown (SIGINT, possibly during a goal): the context may already be shut down, so nothing
can be created or sent any more (a timer then raised RCLError, exit 1); the server is destroyed at
once and a client sees it vanish instead of a result.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass

from bridge_interfaces.action import PickAndPlace
from geometry_msgs.msg import Point
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.action.server import ServerGoalHandle
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.task import Future
from rclpy.time import Time
from sensor_msgs.msg import JointState

from collab_tools.input_guard import ECHO_LIMIT
from collab_tools.qos import SENSOR_OUT

from .core.arm import Arm, Outcome, PickPlaceTask
from .entity_adapters import EntityAdapter, RejectFn, register_adapter

#: Feedback is published again when progress grew by this much within one phase.
FEEDBACK_PROGRESS_STEP = 0.05
#: Wall-clock period (s) at which an orphaned server checks whether it can be destroyed.
ORPHAN_CHECK_PERIOD = 0.5


@dataclass
class _RunningGoal:
    goal_handle: ServerGoalHandle
    task: PickPlaceTask
    done: Future
    adapter: ArmAdapter
    last_phase: str = ''
    last_progress: float = -1.0


class _PickAndPlaceServer:
    """The <arm>/pick_and_place action server of one arm name on one node."""

    _by_node: weakref.WeakKeyDictionary[Node, dict[str, _PickAndPlaceServer]] = weakref.WeakKeyDictionary()

    @classmethod
    def for_arm(cls, node: Node, arm_name: str) -> _PickAndPlaceServer:
        servers = cls._by_node.setdefault(node, {})
        if arm_name not in servers:
            servers[arm_name] = cls(node, arm_name)
        return servers[arm_name]

    def __init__(self, node: Node, arm_name: str):
        self.node = node
        self.arm_name = arm_name
        self.action_name = f'{arm_name}/pick_and_place'
        self.adapter: ArmAdapter | None = None
        self.running: _RunningGoal | None = None
        self._orphan_timer = None
        self._logger = node.get_logger().get_child(arm_name)
        self.server = ActionServer(node, PickAndPlace, self.action_name, execute_callback=self._execute,
                                   goal_callback=self._on_goal, cancel_callback=self._on_cancel)

    # -- adapter hand-over ------------------------------------------------------------

    def attach(self, adapter: ArmAdapter) -> None:
        self.adapter = adapter
        self._stop_orphan_timer()

    def detach(self, adapter: ArmAdapter, node_closing: bool = False) -> None:
        """``adapter`` goes (a scene reset, or ``node_closing``: the node itself is destroyed)."""
        if self.adapter is adapter:
            self.adapter = None
        running = self.running
        if running is not None and running.adapter is adapter:
            adapter.entity.abort('the bridge is shutting down while the arm was moving' if node_closing
                                 else 'the scene was reset while the arm was moving')
            if not running.done.done():
                running.done.set_result(True)
        # A shut-down context (SIGINT during a reset) can create nothing, not even the orphan timer.
        if self.running is None or node_closing or not self.node.context.ok():
            self._destroy()
        elif self._orphan_timer is None:
            # Keep the server until the aborted goal's result is out, or a new adapter adopts it.
            self._orphan_timer = self.node.create_timer(
                ORPHAN_CHECK_PERIOD, self._check_orphan, clock=Clock(clock_type=ClockType.STEADY_TIME))

    def _check_orphan(self) -> None:
        if self.adapter is not None:
            self._stop_orphan_timer()
        elif self.running is None:
            self._destroy()

    def _stop_orphan_timer(self) -> None:
        if self._orphan_timer is not None:
            self.node.destroy_timer(self._orphan_timer)
            self._orphan_timer = None

    def _destroy(self) -> None:
        self._stop_orphan_timer()
        servers = self._by_node.get(self.node, {})
        if servers.get(self.arm_name) is self:
            del servers[self.arm_name]
        if self.server is not None:
            self.server.destroy()
            self.server = None

    # -- action callbacks ---------------------------------------------------------------

    def _on_goal(self, goal: PickAndPlace.Goal) -> GoalResponse:
        # Accepted always: the core judges the goal when it starts and says why in the result.
        # What a log line echoes of a goal is capped (a forged name or region can be megabytes).
        self._logger.info(f"goal: move '{goal.object_name[:80]}' into place_region "
                          f'{[round(float(v), 4) for v in goal.place_region[:8]]}')
        return GoalResponse.ACCEPT

    def _on_cancel(self, goal_handle: ServerGoalHandle) -> CancelResponse:
        running = self.running
        if running is None or running.goal_handle is not goal_handle:
            self._logger.info('cancel refused: that goal is not running')
            return CancelResponse.REJECT
        if not running.adapter.entity.cancel('canceled by the client'):
            self._logger.info(f"cancel refused: '{running.task.object_name}' was already released; "
                              'the arm is only retreating')
            return CancelResponse.REJECT
        self._logger.info(f"canceling: '{running.task.object_name}' goes back to where it was picked")
        return CancelResponse.ACCEPT

    async def _execute(self, goal_handle: ServerGoalHandle) -> PickAndPlace.Result:
        goal = goal_handle.request
        adapter = self.adapter
        if adapter is None:
            task = PickPlaceTask(goal.object_name, tuple(goal.place_region))
            task.finish(Outcome.ABORTED, f"arm '{self.arm_name}' is not in the current scene")
        else:
            try:
                task = adapter.entity.start_pick_and_place(adapter.node.scene, goal.object_name,
                                                           goal.place_region)
            except Exception as error:  # noqa: BLE001 - a bug must not end as an empty 'PLACED' result
                self._logger.error(f'internal error while starting the goal: {error!r}')
                task = PickPlaceTask(goal.object_name, tuple(goal.place_region))
                task.finish(Outcome.ABORTED, f'internal error in the bridge: {error!r}')
        if not task.done:
            running = _RunningGoal(goal_handle, task, Future(), adapter)
            self.running = running
            adapter.publish_feedback(running)
            try:
                await running.done
            finally:
                if self.running is running:
                    self.running = None
        return self._finish(goal_handle, task)

    def _finish(self, goal_handle: ServerGoalHandle, task: PickPlaceTask) -> PickAndPlace.Result:
        result = PickAndPlace.Result(outcome=int(task.outcome), success=task.outcome == Outcome.PLACED,
                                     message=echo_capped(task.message))
        if task.placed_position is not None:
            result.placed_position = Point(x=task.placed_position[0], y=task.placed_position[1],
                                           z=task.placed_position[2])
        if task.outcome == Outcome.PLACED:
            goal_handle.succeed()
        elif goal_handle.is_cancel_requested:
            goal_handle.canceled()
        else:
            goal_handle.abort()
        # Two call sites: rclpy loggers refuse a severity that changes between calls of one line.
        if task.outcome == Outcome.PLACED:
            self._logger.info(f'{task.outcome.name}: {result.message}')
        else:
            self._logger.warn(f'{task.outcome.name}: {result.message}')
        return result


def echo_capped(text: str, limit: int = 4 * ECHO_LIMIT) -> str:
    """A result message (which may echo a forged goal's fields) as long as a reader can use."""
    return text if len(text) <= limit else text[:limit] + f'... ({len(text) - limit} more characters)'


class ArmAdapter(EntityAdapter):
    """Serves <arm>/pick_and_place and publishes <arm>/joint_states."""

    def __init__(self, node: Node, entity: Arm, reject: RejectFn):
        super().__init__(node, entity, reject)
        self.joint_state_pub = node.create_publisher(JointState, f'{entity.name}/joint_states', SENSOR_OUT)
        self._ros_objects.append(self.joint_state_pub)
        self._next_joint_state = 0.0
        self.action = _PickAndPlaceServer.for_arm(node, entity.name)
        self.action.attach(self)

    def on_tick(self, sim_time: float) -> None:
        running = self.action.running
        if running is not None and running.adapter is self:
            self.publish_feedback(running)
            if running.task.done and not running.done.done():
                running.done.set_result(True)
        if sim_time + 1e-9 >= self._next_joint_state:
            # Same rate as the ground truth (simulated time).
            self._next_joint_state = sim_time + 1.0 / self.node.ground_truth_rate
            self.publish_joint_state(sim_time)

    def on_rate_change(self, sim_time: float) -> None:
        self._next_joint_state = min(self._next_joint_state, sim_time + 1.0 / self.node.ground_truth_rate)

    def publish_feedback(self, running: _RunningGoal) -> None:
        task = running.task
        if task.phase == running.last_phase and task.progress < running.last_progress + FEEDBACK_PROGRESS_STEP:
            return
        running.last_phase, running.last_progress = task.phase, task.progress
        running.goal_handle.publish_feedback(PickAndPlace.Feedback(phase=task.phase,
                                                                   progress=float(task.progress)))

    def publish_joint_state(self, sim_time: float) -> None:
        names, positions, velocities, efforts = self.entity.joint_state()
        msg = JointState(name=names, position=[float(v) for v in positions],
                         velocity=[float(v) for v in velocities], effort=[float(v) for v in efforts])
        msg.header.stamp = Time(nanoseconds=int(round(sim_time * 1e9))).to_msg()
        self.joint_state_pub.publish(msg)

    def destroy(self, node_closing: bool = False) -> None:
        super().destroy(node_closing)
        self.action.detach(self, node_closing)


register_adapter(Arm, ArmAdapter)

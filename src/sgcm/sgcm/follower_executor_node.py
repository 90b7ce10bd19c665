"""follower_executor: the SGCM follower arm.

Hears only the leader's Guidance (one-way communication) and senses the table through
the top-view camera. For every new round it waits until the table has settled after the
leader's move, chooses its move by its configured behaviour (obedient, myopic,
zero_trust, random, adversarial; see sgcm.core.follower_behaviour), executes it through
/<follower_arm>/pick_and_place and reports what it did on /sgcm/follower_report.
"""

import sys

from bridge_interfaces.action import PickAndPlace
from rclpy.action import ActionClient
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.task import Future
from rclpy.time import Time
from collab_tools.node_support import ConfigurationError, declare as declare_parameter, run
from sgcm_interfaces.msg import FollowerReport, Guidance

from .camera_input import CameraInput
from .core.follower_behaviour import Follower, FollowerSettings
from .core.rearrangement import EMPTY, FOLLOWER, LEADER, RearrangementModel
from .core.task_config import TaskConfigError, load_task
from .ros_conversions import action_from_msg, counts_from_msg, move_msg, pick_and_place_goal


class FollowerExecutor(Node):
    def __init__(self):
        super().__init__('follower_executor')
        declare = lambda *spec: declare_parameter(self, *spec)  # noqa: E731
        declare('task_file', '', 'task YAML (config/sgcm/task.yaml)')
        declare('behaviour', 'obedient', 'obedient | myopic | zero_trust | random | adversarial')
        declare('deviation_probability', 0.0, 'random behaviour: probability of a random move per round')
        declare('deviation_rounds', [0], 'random behaviour: rounds with a random move (0 = none)')
        declare('seed', 0, 'seed of the random behaviour')
        declare('follower_arm', 'follower_arm', 'arm entity the follower drives')
        declare('camera', 'top_camera', 'camera namespace')
        declare('settle_time', 0.5, 'sim seconds after the guidance before observing the table')
        declare('exit_when_done', True, 'exit when the leader announces the end of the task')
        p = lambda name: self.get_parameter(name).value  # noqa: E731
        if not p('task_file'):
            raise ConfigurationError('parameter task_file: required (path to the task YAML)')
        try:
            self.task = load_task(p('task_file'))
        except TaskConfigError as error:
            raise ConfigurationError(f'parameter task_file: {error}') from None
        self.model = RearrangementModel(self.task)
        rounds = tuple(int(r) for r in p('deviation_rounds') if int(r) != 0)
        try:
            settings = FollowerSettings(p('behaviour'), float(p('deviation_probability')), rounds)
        except (TypeError, ValueError) as error:
            raise ConfigurationError(f'parameter {error}') from None
        self.settings = settings
        self.follower = Follower(self.model, settings, seed=int(p('seed')))
        self.settle = Duration(seconds=float(p('settle_time')))
        self.exit_when_done = bool(p('exit_when_done'))
        self.camera = CameraInput(self, self.task, p('camera'))
        self.arm = ActionClient(self, PickAndPlace, f"/{p('follower_arm')}/pick_and_place")
        reliable = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
        self.report_pub = self.create_publisher(FollowerReport, '/sgcm/follower_report', reliable)
        self.create_subscription(Guidance, '/sgcm/guidance', self._on_guidance, reliable)
        self.finished = Future()
        self.last_round = 0
        self.pending = None     # guidance of the round being handled
        self.busy = False
        self.create_timer(0.05, self._tick)
        self.get_logger().info(f'behaviour {settings.behaviour}'
                               + (f', deviation p={settings.deviation_probability}, rounds {list(rounds)}'
                                  if settings.behaviour == 'random' else ''))

    def _on_guidance(self, msg: Guidance) -> None:
        if msg.task_complete or msg.status:
            self.get_logger().info(f'the leader ended the task: {msg.status or "goal reached"}')
            if not self.finished.done():
                self.finished.set_result(True)
            return
        if msg.round <= self.last_round:
            return  # already handled (duplicate)
        try:
            round_state = counts_from_msg(self.task, msg.state)
            leader_action = action_from_msg(self.model, LEADER, msg.leader_move, 'leader_move')
            recommended = action_from_msg(self.model, FOLLOWER, msg.recommended_follower_move,
                                          'recommended_follower_move')
        except ValueError as error:
            self.get_logger().error(f'dropped malformed guidance for round {msg.round}: {error}')
            return
        self.last_round = msg.round
        self.pending = (msg.round, Time.from_msg(msg.header.stamp) + self.settle, round_state,
                        leader_action, recommended)

    def _tick(self) -> None:
        if self.pending is None or self.busy:
            return
        number, ready_after, round_state, leader_action, recommended = self.pending
        stamp = self.camera.frame_time()
        if stamp is None or stamp < ready_after or not self.arm.server_is_ready():
            return
        try:
            estimate = self.camera.estimate()
        except ValueError as error:
            self.get_logger().warn(f'cannot use the camera frame: {error}', throttle_duration_sec=5.0)
            return
        self.pending = None
        seen = self.model.state_of(estimate.counts)
        choice = self.follower.choose(number, seen, round_state, leader_action, recommended)
        report = FollowerReport(round=number, behaviour=self.settings.behaviour,
                                move=move_msg(self.model, FOLLOWER, choice.action), deviated=choice.deviated)
        self.get_logger().info(f'round {number}: {self.model.describe(FOLLOWER, choice.action)} '
                               f'({choice.reason})')
        if choice.action == EMPTY:
            self._report(report, True, 'no move')
            return
        try:
            goal = pick_and_place_goal(self.model, FOLLOWER, choice.action, estimate)
        except ValueError as error:
            self._report(report, False, f'{error}: no effect')
            return
        self.busy = True
        self.arm.send_goal_async(goal).add_done_callback(lambda f: self._on_goal_response(f, report))

    def _on_goal_response(self, future, report: FollowerReport) -> None:
        handle = future.result()
        if not handle.accepted:
            self._report(report, False, 'the arm rejected the move')
            return
        handle.get_result_async().add_done_callback(
            lambda f: self._report(report, bool(f.result().result.success), f.result().result.message))

    def _report(self, report: FollowerReport, succeeded: bool, message: str) -> None:
        report.succeeded = succeeded
        report.message = message
        report.header.stamp = self.get_clock().now().to_msg()
        self.report_pub.publish(report)
        self.busy = False


def main(args=None) -> int:
    return run(FollowerExecutor, 'follower_executor', args)


if __name__ == '__main__':
    sys.exit(main())

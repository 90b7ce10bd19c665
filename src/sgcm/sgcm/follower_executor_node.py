"""follower_executor: the SGCM follower arm.

Runs in its arm's namespace (``ros2 run sgcm follower_executor --ros-args -r __ns:=/follower_arm``).
Hears only the leader's Guidance on ``<team>/sgcm/guidance`` (one-way communication) and
senses the table through the top-view camera. For every new round it waits until the table
has settled after the leader's move, chooses its move by its configured behaviour (obedient,
myopic, zero_trust, random, adversarial; see sgcm.core.follower_behaviour), executes it
through the arm's ``pick_and_place`` action and reports what it did on
``<team>/sgcm/follower_report``.

Dynamic parameter: settle_time (applied to the round in progress). The behaviour and its
deviations define the experiment's follower and stay as started (read-only).
"""

import sys

from bridge_interfaces.action import PickAndPlace
from rclpy.action import ActionClient
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.task import Future
from rclpy.time import Time
from collab_tools.names import RobotNode
from collab_tools.node_support import ConfigurationError, run
from collab_tools.parameters import NodeParameters
from collab_tools.qos import RELIABLE
from sgcm_interfaces.msg import FollowerReport, Guidance

from .camera_input import CameraInput, check_camera, declare_image_transport
from .core.follower_behaviour import BEHAVIOURS, Follower, FollowerSettings
from .core.rearrangement import EMPTY, FOLLOWER, LEADER, RearrangementModel
from .core.task_config import TaskConfigError, load_task
from .ros_conversions import FOLLOWER_REPORT, GUIDANCE, action_from_msg, counts_from_msg, move_msg, \
    pick_and_place_goal


class FollowerExecutor(Node):
    def __init__(self):
        super().__init__('follower_executor')
        params = self.params = NodeParameters(self)
        self.names = RobotNode(self, params)
        task_file = params.declare('task_file', '', 'task YAML (config/sgcm/task.yaml)', required=True)
        behaviour = params.declare('behaviour', 'obedient', 'how the follower chooses his move',
                                   choices=BEHAVIOURS)
        probability = params.declare('deviation_probability', 0.0,
                                     'random behaviour: probability of a random move per round', low=0.0, high=1.0)
        deviation_rounds = params.declare('deviation_rounds', [0], 'random behaviour: rounds with a random '
                                          'move, numbered from 1 (0 = none)', low=0)
        seed = params.declare('seed', 0, 'seed of the random behaviour', low=0)
        camera = params.declare('camera', 'top_camera', 'camera namespace, under the team namespace',
                                check=check_camera)
        transport = declare_image_transport(params)
        settle_time = params.declare('settle_time', 0.5, 'sim seconds after the guidance before observing '
                                     'the table (applied to the round in progress)', low=0.0,
                                     on_change=self._set_settle_time)
        self.exit_when_done = params.declare('exit_when_done', True,
                                             'exit when the leader announces the end of the task')
        try:
            self.task = load_task(task_file)
        except TaskConfigError as error:
            raise ConfigurationError(f'parameter task_file: {error}') from None
        self.model = RearrangementModel(self.task)
        rounds = tuple(int(r) for r in deviation_rounds if int(r) != 0)
        self.settings = settings = FollowerSettings(behaviour, probability, rounds)
        self.follower = Follower(self.model, settings, seed=seed)
        self._set_settle_time(settle_time)
        self.camera = CameraInput(self, self.task, self.names.team(camera), transport)
        self.arm = ActionClient(self, PickAndPlace, 'pick_and_place')
        self.report_pub = self.create_publisher(FollowerReport, self.names.team(FOLLOWER_REPORT), RELIABLE)
        self.create_subscription(Guidance, self.names.team(GUIDANCE), self._on_guidance, RELIABLE)
        self.finished = Future()
        self.last_round = 0
        self.pending = None     # guidance of the round being handled
        self.busy = False
        self.create_timer(0.05, self._tick)
        self.get_logger().info(f'arm {self.names.robot}, behaviour {settings.behaviour}'
                               + (f', deviation p={settings.deviation_probability}, rounds {list(rounds)}'
                                  if settings.behaviour == 'random' else ''))

    def _set_settle_time(self, value: float) -> None:
        self.settle = Duration(seconds=float(value))

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
        # The settling is counted from the guidance's stamp when the frame is checked, so a
        # settle_time set meanwhile applies to this round too.
        self.pending = (msg.round, Time.from_msg(msg.header.stamp), round_state, leader_action, recommended)

    def _tick(self) -> None:
        if self.pending is None or self.busy:
            return
        number, guided_at, round_state, leader_action, recommended = self.pending
        stamp = self.camera.frame_time()
        if stamp is None or stamp < guided_at + self.settle or not self.arm.server_is_ready():
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

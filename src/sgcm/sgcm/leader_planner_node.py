"""leader_planner: the SGCM leader arm (Algorithm 1 on the simulated table).

Each round: estimate the state from the top-view camera (labels + RGB; no ground
truth), solve the feedback Stackelberg equilibrium over the horizon (or act greedily,
for the baseline), execute her own move through /<leader_arm>/pick_and_place, publish
the Guidance (her move and its outcome, the recommended follower move, predicted
values), then wait until the follower reports the round over, let the table settle and
observe again. The task ends at the goal, when a round passes with both arms idle
(stuck), or at the round limit; the node then exits (exit_when_done) so an
orchestration script can wait for it.
"""

import sys

import numpy as np
from bridge_interfaces.action import PickAndPlace
from rclpy.action import ActionClient
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.task import Future
from collab_tools.node_support import ConfigurationError, declare as declare_parameter, run
from sgcm_interfaces.msg import FollowerReport, Guidance

from .camera_input import CameraInput
from .core.follower_behaviour import greedy_action
from .core.fse import FSEPlanner
from .core.rearrangement import EMPTY, FOLLOWER, LEADER, RearrangementModel
from .core.task_config import TaskConfigError, load_task
from .ros_conversions import grid_state_msg, move_msg, pick_and_place_goal

STRATEGIES = ('sgcm', 'greedy')


class LeaderPlanner(Node):
    def __init__(self):
        super().__init__('leader_planner')
        declare = lambda *spec: declare_parameter(self, *spec)  # noqa: E731
        declare('task_file', '', 'task YAML (config/sgcm/task.yaml)')
        declare('horizon', 0, 'T; 0 = the task file game.horizon')
        declare('solver', 'fast', 'stage-game solver: fast | milp')
        declare('strategy', 'sgcm', 'sgcm (guidance) | greedy (baseline: no guidance)')
        declare('leader_arm', 'leader_arm', 'arm entity the leader drives')
        declare('camera', 'top_camera', 'camera namespace')
        declare('follower_timeout', 60.0, 'sim seconds to wait for the follower to end a round')
        declare('settle_time', 0.5, 'sim seconds to let the table settle before observing')
        declare('round_limit', 0, 'rounds before giving up; 0 = the task file game.round_limit')
        declare('seed', 0, 'seed for sampling a mixed leader policy')
        declare('exit_when_done', True, 'exit the node when the task has ended')
        p = lambda name: self.get_parameter(name).value  # noqa: E731
        if not p('task_file'):
            raise ConfigurationError('parameter task_file: required (path to the task YAML)')
        horizon = p('horizon')
        if not isinstance(horizon, int) or horizon < 0:
            raise ConfigurationError(f'parameter horizon: must be an integer >= 0 (got {horizon!r})')
        try:
            self.task = load_task(p('task_file'), {'horizon': horizon} if horizon else None)
        except TaskConfigError as error:
            raise ConfigurationError(f'parameter task_file: {error}') from None
        self.strategy = p('strategy')
        if self.strategy not in STRATEGIES:
            raise ConfigurationError(f"parameter strategy: must be one of {', '.join(STRATEGIES)} "
                                     f"(got '{self.strategy}')")
        self.model = RearrangementModel(self.task)
        try:
            self.planner = FSEPlanner(self.model, solver=p('solver'))
        except ValueError as error:
            raise ConfigurationError(f'parameter {error}') from None
        for name in ('follower_timeout', 'settle_time'):
            value = p(name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or value < 0:
                raise ConfigurationError(f'parameter {name}: must be a number >= 0 (got {value!r})')
        self.follower_timeout = Duration(seconds=float(p('follower_timeout')))
        self.settle = Duration(seconds=float(p('settle_time')))
        self.round_limit = p('round_limit') or self.task.round_limit
        self.exit_when_done = bool(p('exit_when_done'))
        self.rng = np.random.default_rng(p('seed'))

        self.camera = CameraInput(self, self.task, p('camera'))
        self.arm = ActionClient(self, PickAndPlace, f"/{p('leader_arm')}/pick_and_place")
        reliable = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
        self.guidance_pub = self.create_publisher(Guidance, '/sgcm/guidance', reliable)
        self.create_subscription(FollowerReport, '/sgcm/follower_report', self._on_report, reliable)
        self.finished = Future()
        self.outcome = ''

        self.round = 0
        self.phase = 'observe'
        self.ready_after = None          # sim time after which a camera frame counts
        self.follower_deadline = None
        self.pending = None              # the round being executed
        self.timer = self.create_timer(0.05, self._tick)
        self.get_logger().info(
            f"strategy {self.strategy}, horizon T={self.planner.horizon}, solver {p('solver')}, "
            f'{self.task.rows}x{self.task.cols} grid, colours {", ".join(self.task.colours)}')

    # --- round state machine ---------------------------------------------------------
    def _tick(self) -> None:
        if self.phase == 'observe':
            self._observe()
        elif self.phase == 'wait_follower' and self.get_clock().now() > self.follower_deadline:
            self.get_logger().warn(f'round {self.round}: no follower report within '
                                   f'{self.follower_timeout.nanoseconds / 1e9:.0f} s; observing anyway')
            self._end_round(follower_idle=False)

    def _observe(self) -> None:
        stamp = self.camera.frame_time()
        if stamp is None or (self.ready_after is not None and stamp < self.ready_after):
            return
        if not self.arm.server_is_ready():
            return
        try:
            estimate = self.camera.estimate()
        except ValueError as error:
            self.get_logger().warn(f'cannot use the camera frame: {error}', throttle_duration_sec=5.0)
            return
        if estimate.off_grid:
            self.get_logger().warn('objects outside the grid are not counted: '
                                   + ', '.join(o.name for o in estimate.off_grid))
        state = self.model.state_of(estimate.counts)
        goal = self.model.goal_state(state)
        if np.array_equal(state, goal):
            self._finish(state, 'goal reached', complete=True)
            return
        if self.round >= self.round_limit:
            self._finish(state, f'round limit {self.round_limit} reached', complete=False)
            return
        self.round += 1
        plan = None
        if self.strategy == 'sgcm':
            plan = self.planner.plan(state)
            action = plan.leader_action
            if len(plan.leader_actions) > 1:
                action = int(self.rng.choice(plan.leader_actions, p=plan.leader_policy))
            recommended = plan.follower_action
        else:
            action, recommended = greedy_action(self.model, state, LEADER), EMPTY
        self.pending = {'state': state, 'estimate': estimate, 'action': action, 'plan': plan,
                        'recommended': recommended}
        self.get_logger().info(
            f'round {self.round}: state\n{self.model.format_state(state)}\nleader: '
            f'{self.model.describe(LEADER, action)}; recommend follower: '
            f'{self.model.describe(FOLLOWER, recommended)}'
            + (f' (v^A={plan.leader_value:.2f}, {plan.stage_games} stage games, '
               f'{plan.seconds * 1e3:.0f} ms)' if plan else ''))
        if action == EMPTY:
            self._publish_guidance(succeeded=True)
            return
        try:
            goal_msg = pick_and_place_goal(self.model, LEADER, action, estimate)
        except ValueError as error:  # cannot happen for an estimate-feasible move; be explicit anyway
            self.get_logger().error(f'round {self.round}: {error}')
            self._publish_guidance(succeeded=False)
            return
        self.phase = 'executing'
        future = self.arm.send_goal_async(goal_msg)
        future.add_done_callback(self._on_goal_response)

    def _on_goal_response(self, future) -> None:
        handle = future.result()
        if not handle.accepted:
            self.get_logger().error(f'round {self.round}: the arm rejected the move')
            self._publish_guidance(succeeded=False)
            return
        handle.get_result_async().add_done_callback(self._on_result)

    def _on_result(self, future) -> None:
        result = future.result().result
        if not result.success:
            self.get_logger().info(f'round {self.round}: leader move not done: {result.message}')
        self._publish_guidance(succeeded=bool(result.success))

    def _publish_guidance(self, succeeded: bool) -> None:
        pending = self.pending
        plan = pending['plan']
        msg = Guidance(round=self.round, horizon=self.planner.horizon, strategy=self.strategy,
                       state=grid_state_msg(self.task, pending['state']),
                       leader_move=move_msg(self.model, LEADER, pending['action']),
                       leader_move_succeeded=succeeded,
                       recommended_follower_move=move_msg(self.model, FOLLOWER, pending['recommended']))
        msg.header.stamp = self.get_clock().now().to_msg()
        if plan is not None:
            msg.leader_policy_moves = [move_msg(self.model, LEADER, int(a)) for a in plan.leader_actions]
            msg.leader_policy_probabilities = [float(x) for x in plan.leader_policy]
            msg.predicted_leader_value = plan.leader_value
            msg.predicted_follower_value = plan.follower_value
            msg.stage_games = plan.stage_games
            msg.planning_seconds = plan.seconds
        self.guidance_pub.publish(msg)
        self.phase = 'wait_follower'
        self.follower_deadline = self.get_clock().now() + self.follower_timeout

    def _on_report(self, msg: FollowerReport) -> None:
        if self.phase != 'wait_follower' or msg.round != self.round:
            return  # a late or duplicate report: the round it belongs to is over
        self._end_round(follower_idle=msg.move.empty)

    def _end_round(self, follower_idle: bool) -> None:
        leader_idle = self.pending['action'] == EMPTY
        self.ready_after = self.get_clock().now() + self.settle
        if leader_idle and follower_idle:
            # Both arms idle away from the goal: the same state comes back, and with it the
            # same decisions (the greedy pair's chattering/stuck case).
            self._finish(self.pending['state'], f'stuck: both arms idle in round {self.round}', complete=False)
            return
        self.phase = 'observe'

    def _finish(self, state: np.ndarray, why: str, complete: bool) -> None:
        msg = Guidance(round=self.round, horizon=self.planner.horizon, strategy=self.strategy,
                       state=grid_state_msg(self.task, state), leader_move=move_msg(self.model, LEADER, EMPTY),
                       leader_move_succeeded=True,
                       recommended_follower_move=move_msg(self.model, FOLLOWER, EMPTY),
                       task_complete=complete, status=why)
        msg.header.stamp = self.get_clock().now().to_msg()
        self.guidance_pub.publish(msg)
        self.phase = 'done'
        self.outcome = why
        self.get_logger().info(f'task ended after {self.round} rounds: {why}')
        if not self.finished.done():
            self.finished.set_result(complete)


def main(args=None) -> int:
    return run(LeaderPlanner, 'leader_planner', args)


if __name__ == '__main__':
    sys.exit(main())

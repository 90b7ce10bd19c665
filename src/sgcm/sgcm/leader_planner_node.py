"""leader_planner: the SGCM leader arm (Algorithm 1 on the simulated table).

Runs in its arm's namespace (``ros2 run sgcm leader_planner --ros-args -r __ns:=/leader_arm``).
Each round: estimate the state from the top-view camera (labels + RGB; no ground
truth), solve the feedback Stackelberg equilibrium over the horizon (or act greedily,
for the baseline), execute her own move through the arm's ``pick_and_place`` action, publish
the Guidance on ``<team>/sgcm/guidance`` (her move and its outcome, the recommended follower
move, predicted values), then wait until the follower reports the round over on
``<team>/sgcm/follower_report``, let the table settle and observe again. The task ends at
the goal, when a round passes with both arms idle (stuck), or at the round limit; the node
then exits (exit_when_done) so an orchestration script can wait for it.

Dynamic parameters (applied from the next decision that uses them): horizon, round_limit,
follower_timeout (also to the wait in progress), settle_time (also to the settling in progress).
"""

import sys

import numpy as np
from bridge_interfaces.action import PickAndPlace
from rclpy.action import ActionClient
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.task import Future
from collab_tools.names import RobotNode
from collab_tools.node_support import ConfigurationError, run
from collab_tools.parameters import NodeParameters
from collab_tools.qos import RELIABLE
from sgcm_interfaces.msg import FollowerReport, Guidance

from .camera_input import CameraInput, check_camera, declare_image_transport
from .core.follower_behaviour import greedy_action
from .core.fse import FSEPlanner
from .core.rearrangement import EMPTY, FOLLOWER, LEADER, RearrangementModel
from .core.stage_game import SOLVERS
from .core.task_config import TaskConfigError, load_task
from .ros_conversions import FOLLOWER_REPORT, GUIDANCE, grid_state_msg, move_msg, pick_and_place_goal

STRATEGIES = ('sgcm', 'greedy')
#: The task file's own range for game.horizon (core.task_config).
MAX_HORIZON = 6


class LeaderPlanner(Node):
    def __init__(self):
        super().__init__('leader_planner')
        params = self.params = NodeParameters(self)
        self.names = RobotNode(self, params)
        task_file = params.declare('task_file', '', 'task YAML (config/sgcm/task.yaml)', required=True)
        horizon = params.declare('horizon', 0, 'T, the prediction horizon; 0 = the task file game.horizon '
                                 '(applied from the next round)', low=0, high=MAX_HORIZON,
                                 on_change=self._set_horizon)
        solver = params.declare('solver', 'fast', 'stage-game solver', choices=tuple(SOLVERS))
        self.strategy = params.declare('strategy', 'sgcm', 'sgcm (guidance) | greedy (baseline: no guidance)',
                                       choices=STRATEGIES)
        camera = params.declare('camera', 'top_camera', 'camera namespace, under the team namespace',
                                check=check_camera)
        transport = declare_image_transport(params)
        follower_timeout = params.declare(
            'follower_timeout', 60.0, 'sim seconds to wait for the follower to end a round '
            '(applied to the wait in progress)', low=0.0, on_change=self._set_follower_timeout)
        settle_time = params.declare('settle_time', 0.5, 'sim seconds to let the table settle before observing '
                                     '(applied to the settling in progress)', low=0.0,
                                     on_change=self._set_settle_time)
        round_limit = params.declare('round_limit', 0, 'rounds before giving up; 0 = the task file '
                                     'game.round_limit (applied at the next observation)', low=0,
                                     on_change=self._set_round_limit)
        seed = params.declare('seed', 0, 'seed for sampling a mixed leader policy', low=0)
        self.exit_when_done = params.declare('exit_when_done', True, 'exit the node when the task has ended')
        try:
            self.task = load_task(task_file)
        except TaskConfigError as error:
            raise ConfigurationError(f'parameter task_file: {error}') from None
        self.model = RearrangementModel(self.task)
        self.solver = solver
        self._set_horizon(horizon)
        self._set_follower_timeout(follower_timeout)
        self._set_settle_time(settle_time)
        self._set_round_limit(round_limit)
        self.rng = np.random.default_rng(seed)

        self.camera = CameraInput(self, self.task, self.names.team(camera), transport)
        self.arm = ActionClient(self, PickAndPlace, 'pick_and_place')
        self.guidance_pub = self.create_publisher(Guidance, self.names.team(GUIDANCE), RELIABLE)
        self.create_subscription(FollowerReport, self.names.team(FOLLOWER_REPORT), self._on_report, RELIABLE)
        self.finished = Future()
        self.outcome = ''

        self.round = 0
        self.phase = 'observe'
        self.round_ended = None          # sim time the last round ended; frames count after + settle
        self.guidance_time = None        # sim time of the round's guidance; the follower has until + timeout
        self.pending = None              # the round being executed
        self.timer = self.create_timer(0.05, self._tick)
        self.get_logger().info(
            f'arm {self.names.robot}, strategy {self.strategy}, horizon T={self.planner.horizon}, '
            f'solver {solver}, {self.task.rows}x{self.task.cols} grid, colours {", ".join(self.task.colours)}')

    # --- dynamic parameters ----------------------------------------------------------
    def _set_horizon(self, value: int) -> None:
        # The next round plans with it; the planner holds no state between rounds.
        self.planner = FSEPlanner(self.model, horizon=value or self.task.horizon, solver=self.solver)

    def _set_follower_timeout(self, value: float) -> None:
        self.follower_timeout = Duration(seconds=float(value))

    def _set_settle_time(self, value: float) -> None:
        self.settle = Duration(seconds=float(value))

    def _set_round_limit(self, value: int) -> None:
        self.round_limit = value or self.task.round_limit

    # --- round state machine ---------------------------------------------------------
    def _tick(self) -> None:
        if self.phase == 'observe':
            self._observe()
        elif self.phase == 'wait_follower' and \
                self.get_clock().now() > self.guidance_time + self.follower_timeout:
            self.get_logger().warn(f'round {self.round}: no follower report within '
                                   f'{self.follower_timeout.nanoseconds / 1e9:.0f} s; observing anyway')
            self._end_round(follower_idle=False)

    def _observe(self) -> None:
        stamp = self.camera.frame_time()
        if stamp is None or (self.round_ended is not None and stamp < self.round_ended + self.settle):
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
        self.guidance_time = self.get_clock().now()

    def _on_report(self, msg: FollowerReport) -> None:
        if self.phase != 'wait_follower' or msg.round != self.round:
            return  # a late or duplicate report: the round it belongs to is over
        self._end_round(follower_idle=msg.move.empty)

    def _end_round(self, follower_idle: bool) -> None:
        leader_idle = self.pending['action'] == EMPTY
        self.round_ended = self.get_clock().now()
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

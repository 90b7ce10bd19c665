"""leader_planner: the SGCM leader arm (Algorithm 1 on the simulated table).

Runs in its arm's namespace (``ros2 run sgcm leader_planner --ros-args -r __ns:=/leader_arm``).
Each round: estimate the state from the top-view camera (labels + RGB; no ground truth; one frame
asked of the camera per round, see sgcm.camera_input), then
the leader's round of the core (sgcm.core.leader_round: goal, stuck, round limit, else the
feedback Stackelberg equilibrium over the horizon, or the greedy baseline), execute her own
move through the arm's ``pick_and_place`` action, publish the Guidance on
``<team>/sgcm/guidance`` (her move and its outcome, the recommended follower move, predicted
values), then wait until the follower reports the round over on ``<team>/sgcm/follower_report``,
let the table settle and observe again. The round logic is sgcm.core.leader_rounds; this node
only turns frames, action results, reports and timers into its events. When the task ends (at
the goal, stuck by sgcm.core.stuck_rule, or at the round limit) the node exits (exit_when_done)
so an orchestration script can wait for it.

A frame is used only when perception accepts it as evidence (sgcm.core.perception_check: every
cube of the camera's legend seen in the grid); else the last good state stays, the camera is
asked again, and after ``perception_fault_after`` s of rejected frames the task ends with a
perception fault (status ``perception fault: ...``, exit code 1). Malformed reports are dropped,
counted and logged once per kind (collab_tools.input_guard), and so are reports from another
sender than her follower or to another leader session than hers (sgcm.core.sessions). Her
guidance carries her name and her session, a random id drawn at start: a restarted leader is a
new session, which the follower follows from its round 1. A round's guidance goes out once the
follower's subscription has matched (at most ANNOUNCE_WAIT s later): guidance is volatile, and
a restarted leader's first round would otherwise be published before discovery and lost.

A move whose goal gets no result (the bridge crashed) is given up (sgcm.arm_client: a timeout and
server loss, on the steady clock) and announced as not done; she plans the next round from the
table she sees once the arm and the camera are back. When the simulated clock goes back (a
restarted or reset simulation) her waits restart from the new time and older frames are dropped.

Parameters: sgcm.core.settings.LEADER_SETTINGS. Dynamic ones (applied from the next decision
that uses them): horizon, round_limit, follower_timeout (also to the wait in progress),
settle_time (also to the settling in progress), perception_fault_after (at once),
arm_goal_timeout and arm_server_lost_after (sgcm.arm_client; also to the goal out).
"""

import sys
import time

import numpy as np
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.task import Future
from rclpy.time import Time
from collab_tools.core.session_following import new_session
from collab_tools.names import RobotNode, join
from collab_tools.input_guard import InputGuard
from collab_tools.node_support import EXIT_TASK_FAILED, run
from collab_tools.parameters import NodeParameters
from collab_tools.qos import RELIABLE
from sgcm_interfaces.msg import FollowerReport, Guidance

from .arm_client import CLOCK_BACK_NS, ArmClient
from .camera_input import CameraInput
from .core.fse_compiled import make_planner
from .core.leader_round import LeaderRound, LeaderTurn, TaskEnd
from .core.leader_rounds import LeaderPhase, LeaderRounds
from .core.perception_check import PerceptionCheck
from .core.rearrangement import EMPTY, FOLLOWER, LEADER, RearrangementModel
from .core.sessions import FollowerReports
from .core.settings import LEADER_SETTINGS, LeaderSettings
from .ros_conversions import FOLLOWER_REPORT, GUIDANCE, grid_state_msg, move_msg, pick_and_place_goal


#: s (steady) a round's guidance waits for the follower's subscription to match before it goes out anyway.
ANNOUNCE_WAIT = 5.0


class LeaderPlanner(Node):
    def __init__(self, node_name: str = 'leader_planner', **node_options):
        super().__init__(node_name, **node_options)
        params = self.params = NodeParameters(self)
        self.names = RobotNode(self, params)
        values = params.declare_schema(LEADER_SETTINGS, on_change={
            'horizon': self._set_horizon, 'follower_timeout': self._set_follower_timeout,
            'settle_time': self._set_settle_time, 'round_limit': self._set_round_limit,
            'perception_fault_after': self._set_perception_fault_after})
        settings = self.settings = LeaderSettings.from_values(values)
        self.task = settings.task
        self.strategy = settings.strategy
        self.exit_when_done = settings.exit_when_done
        self.model = RearrangementModel(self.task)
        self.leader = LeaderRound(self.model, settings.strategy, rng=np.random.default_rng(settings.seed),
                                  round_limit=settings.round_limit, moves_can_fail=settings.moves_can_fail)
        self._set_horizon(settings.horizon)
        self._set_follower_timeout(settings.follower_timeout)
        self._set_settle_time(settings.settle_time)
        self.rounds = LeaderRounds(self.leader, self)
        self.perception = PerceptionCheck(values['perception_fault_after'])
        self.look_again = None           # sim time of the next look while frames are rejected
        self.exit_code = 0

        self.camera = CameraInput(self, self.task, self.names.team(settings.camera), settings.image_transport,
                                  params=params)
        self.arm = ArmClient(self, params)
        self.session = new_session()
        self.follower = FollowerReports(self.names.team(values['follower']), self.session)
        self.clock_seen = None           # the newest time of the node's clock seen: going back = a restart
        self.guidance_pub = self.create_publisher(Guidance, self.names.team(GUIDANCE), RELIABLE)
        self.inputs = InputGuard.of(self)
        self.inputs.subscribe(FollowerReport, self.names.team(FOLLOWER_REPORT), self._on_report, RELIABLE)
        self.finished = Future()
        self.outcome = ''
        self.round_ended = None          # sim time the last round ended; frames count after + settle
        self.guidance_time = None        # sim time of the round's guidance; the follower has until + timeout
        self.unsent = None               # (guidance, steady time) held until the follower listens
        self.estimate = None             # the camera estimate the round in progress was decided on
        self.timer = self.create_timer(0.05, self._tick)
        self.get_logger().info(
            f'arm {self.names.robot}, strategy {self.strategy}, horizon T={self.leader.planner.horizon}, '
            f'planner {settings.planner}, solver {settings.solver}, {self.task.rows}x{self.task.cols} grid, '
            f'colours {", ".join(self.task.colours)}; session {self.session:#x}')

    # --- dynamic parameters ----------------------------------------------------------
    def _set_horizon(self, value: int) -> None:
        # The next round plans with it; the planner holds no state between rounds.
        self.leader.planner = make_planner(self.model, value or self.task.horizon, self.settings.solver,
                                           self.settings.planner)   # kernel: warmed up (numba) when built

    def _set_follower_timeout(self, value: float) -> None:
        self.follower_timeout = Duration(seconds=float(value))

    def _set_settle_time(self, value: float) -> None:
        self.settle = Duration(seconds=float(value))

    def _set_round_limit(self, value: int) -> None:
        self.leader.round_limit = value or None

    def _set_perception_fault_after(self, value: float) -> None:
        self.perception.fault_after = float(value)

    # --- events for the core's rounds ------------------------------------------------
    def _clock_went_back(self) -> None:
        now = self.get_clock().now()
        if self.clock_seen is not None and now.nanoseconds < self.clock_seen.nanoseconds - CLOCK_BACK_NS:
            self.get_logger().warning(f'the clock went back ({self.clock_seen.nanoseconds / 1e9:.1f} s -> '
                                      f'{now.nanoseconds / 1e9:.1f} s: a restarted simulation); waits restart now')
            self.guidance_time = now if self.guidance_time is not None else None
            self.round_ended = now if self.round_ended is not None else None
            self.look_again = None
            self.camera.forget_frames()
            self.arm.abandon('the simulation restarted (the clock went back)')
        self.clock_seen = now

    def _tick(self) -> None:
        self._clock_went_back()
        phase = self.rounds.phase
        if phase is LeaderPhase.OBSERVING:
            self._observe()
        elif phase is LeaderPhase.AWAITING_FOLLOWER and self.unsent is not None:
            self._send_guidance()
        elif phase is LeaderPhase.AWAITING_FOLLOWER and \
                self.get_clock().now() > self.guidance_time + self.follower_timeout:
            self.get_logger().warn(f'round {self.rounds.turn.round}: no follower report within '
                                   f'{self.follower_timeout.nanoseconds / 1e9:.0f} s; observing anyway')
            self.rounds.follower_timed_out()
            self.round_ended = self.get_clock().now()

    def _observe(self) -> None:
        settled = None if self.round_ended is None else self.round_ended + self.settle
        if self.look_again is not None and (settled is None or self.look_again > settled):
            settled = self.look_again                       # a newer frame than the one rejected
        stamp = self.camera.frame_time(not_before=settled)   # on demand: asks for a frame once settled
        if stamp is None or (settled is not None and stamp < settled):
            return
        if not self.arm.server_is_ready():
            return
        try:
            estimate = self.camera.estimate()
        except ValueError as error:
            self.get_logger().warn(f'cannot use the camera frame: {error}', throttle_duration_sec=5.0)
            return
        verdict = self.perception.judge(estimate, len(self.camera.cube_labels), stamp.nanoseconds * 1e-9)
        if not verdict.accepted:
            self._rejected_frame(verdict)
            return
        self.look_again = None
        self.estimate = estimate
        self.rounds.table_seen(self.model.state_of(estimate.counts))

    def _rejected_frame(self, verdict) -> None:
        if verdict.fault:
            self.get_logger().error(f'perception fault: no usable camera frame for {verdict.rejected_for:.1f} s '
                                    f'({verdict.reason}); the task ends unfinished')
            last = self.perception.last_good
            state = self.model.state_of(last.counts) if last is not None else \
                np.zeros(self.task.cells * len(self.task.colours), dtype=np.int64)
            self.exit_code = EXIT_TASK_FAILED
            self.rounds.perception_fault(verdict.reason, state)
            return
        self.get_logger().warn(f'camera frame rejected, not used as the table state: {verdict.reason}; looking '
                               'again', throttle_duration_sec=5.0)
        self.look_again = Time(nanoseconds=int(verdict.retry_at * 1e9), clock_type=self.get_clock().clock_type)

    def _on_report(self, msg: FollowerReport) -> None:
        self.inputs.stamp(msg.header.stamp)     # an invalid stamp: dropped, counted, logged by the guard
        # Not her follower's, or to another session of hers: MalformedInput, counted and logged by the guard.
        previous = self.follower.check(msg.sender, msg.session, msg.leader_session)
        if previous is not None:
            self.get_logger().warning(f'the follower\'s session changed ({previous:#x} -> {msg.session:#x}): '
                                      'he restarted')
        # A late or duplicate report (for a round that is over) is ignored by the core.
        if self.rounds.follower_reported(msg.round, not msg.move.empty, bool(msg.succeeded), msg.behaviour):
            self.round_ended = self.get_clock().now()

    # --- the core's effects ----------------------------------------------------------
    def execute(self, turn: LeaderTurn) -> None:
        self._log_turn(turn)
        try:
            goal_msg = pick_and_place_goal(self.model, LEADER, turn.action, self.estimate)
        except ValueError as error:  # cannot happen for an estimate-feasible move; be explicit anyway
            self.get_logger().error(f'round {turn.round}: {error}')
            self.rounds.move_done(False)
            return
        self.arm.send(goal_msg, self._on_arm_done)

    def _on_arm_done(self, success: bool, message: str) -> None:
        if not success:
            self.get_logger().info(f'round {self.rounds.turn.round}: leader move not done: {message}')
        self.rounds.move_done(success)

    def announce(self, turn: LeaderTurn, succeeded: bool) -> None:
        if turn.action == EMPTY:
            self._log_turn(turn)
        plan = turn.plan
        recommended = EMPTY if turn.recommended is None else turn.recommended
        msg = Guidance(sender=self.get_fully_qualified_name(), session=self.session, round=turn.round,
                       horizon=self.leader.planner.horizon, strategy=self.strategy,
                       state=grid_state_msg(self.task, turn.state),
                       leader_move=move_msg(self.model, LEADER, turn.action), leader_move_succeeded=succeeded,
                       recommended_follower_move=move_msg(self.model, FOLLOWER, recommended))
        if plan is not None:
            msg.leader_policy_moves = [move_msg(self.model, LEADER, int(a)) for a in plan.leader_actions]
            msg.leader_policy_probabilities = [float(x) for x in plan.leader_policy]
            msg.predicted_leader_value = plan.leader_value
            msg.predicted_follower_value = plan.follower_value
            msg.stage_games = plan.stage_games
            msg.planning_seconds = plan.seconds
        self.unsent = (msg, time.monotonic())
        self._send_guidance()

    def _send_guidance(self) -> None:
        """Publish the round's guidance once the follower's subscription has matched (guidance is volatile: a
        restarted leader's round 1 went out before discovery and was lost), or after ANNOUNCE_WAIT s without."""
        msg, since = self.unsent
        topic = self.guidance_pub.topic_name
        readers = self.get_subscriptions_info_by_topic(topic)
        listening = any(join(r.node_namespace, r.node_name) == self.follower.follower for r in readers) and \
            self.guidance_pub.get_subscription_count() >= len(readers)
        if not listening and time.monotonic() - since < ANNOUNCE_WAIT:
            return
        if not listening:
            self.get_logger().warning(f'round {msg.round}: {self.follower.follower} does not subscribe to {topic} '
                                      f'after {ANNOUNCE_WAIT:g} s; publishing the guidance anyway')
        msg.header.stamp = self.get_clock().now().to_msg()
        self.guidance_pub.publish(msg)
        self.unsent = None
        self.guidance_time = self.get_clock().now()

    def finish(self, end: TaskEnd) -> None:
        msg = Guidance(sender=self.get_fully_qualified_name(), session=self.session, round=end.rounds,
                       horizon=self.leader.planner.horizon, strategy=self.strategy,
                       state=grid_state_msg(self.task, end.state), leader_move=move_msg(self.model, LEADER, EMPTY),
                       leader_move_succeeded=True,
                       recommended_follower_move=move_msg(self.model, FOLLOWER, EMPTY),
                       task_complete=end.complete, status=end.reason)
        msg.header.stamp = self.get_clock().now().to_msg()
        self.guidance_pub.publish(msg)
        self.outcome = end.reason
        self.get_logger().info(f'task ended after {end.rounds} rounds: {end.reason}')
        if not self.finished.done():
            self.finished.set_result(end.complete)

    def _log_turn(self, turn: LeaderTurn) -> None:
        plan = turn.plan
        recommended = EMPTY if turn.recommended is None else turn.recommended
        self.get_logger().info(
            f'round {turn.round}: state\n{self.model.format_state(turn.state)}\nleader: '
            f'{self.model.describe(LEADER, turn.action)}; recommend follower: '
            f'{self.model.describe(FOLLOWER, recommended)}'
            + (f' (v^A={plan.leader_value:.2f}, {plan.stage_games} stage games, '
               f'{plan.seconds * 1e3:.0f} ms)' if plan else ''))


def main(args=None) -> int:
    return run(LeaderPlanner, 'leader_planner', args)


if __name__ == '__main__':
    sys.exit(main())

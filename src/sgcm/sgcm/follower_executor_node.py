"""follower_executor: the SGCM follower arm.

Runs in its arm's namespace (``ros2 run sgcm follower_executor --ros-args -r __ns:=/follower_arm``).
Hears only the leader's Guidance on ``<team>/sgcm/guidance`` (one-way communication) and
senses the table through the top-view camera. For every new round it waits until the table
has settled after the leader's move, chooses its move by its configured behaviour (obedient,
myopic, zero_trust, random, adversarial; see sgcm.core.follower_behaviour), executes it
through the arm's ``pick_and_place`` action and reports what it did on
``<team>/sgcm/follower_report``. The round logic is sgcm.core.follower_rounds; this node only
turns messages, frames and action results into its events.

A frame is used only when perception accepts it as evidence (sgcm.core.perception_check); else
he looks again, and after ``perception_fault_after`` s of rejected frames he logs a perception
fault (once per round) and keeps looking: the leader's follower timeout ends the round. Malformed
guidance (a field, an invalid stamp) is dropped, counted and logged once per kind
(collab_tools.input_guard), and so is guidance that is not from the current session of his leader
(another sender, an ended session, a round out of order or far ahead, a task end of another
session: sgcm.core.sessions). A restarted leader (a new session that begins) is followed from its
first round; a restarted follower joins the session under way. His reports carry his name, his
session and the leader session they answer.

A move whose goal gets no result (the bridge crashed) is given up (sgcm.arm_client: a timeout and
server loss, on the steady clock) and reported as not done. When the simulated clock goes back (a
restarted or reset simulation) the settling restarts from the new time and older frames are dropped.

Parameters: sgcm.core.settings.FOLLOWER_SETTINGS. Dynamic: settle_time (applied to the round in
progress), perception_fault_after (at once), arm_goal_timeout and arm_server_lost_after (sgcm.arm_client,
also to the goal out). The behaviour and its deviations define the experiment's follower and stay as
started (read-only), as do leader and max_round_jump.
"""

import sys

from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.task import Future
from rclpy.time import Time
from collab_tools.core.input_checks import MalformedInput, error_kind
from collab_tools.core.session_following import Followed, new_session
from collab_tools.input_guard import InputGuard
from collab_tools.names import RobotNode
from collab_tools.node_support import run
from collab_tools.parameters import NodeParameters
from collab_tools.qos import RELIABLE
from sgcm_interfaces.msg import FollowerReport, Guidance

from .arm_client import CLOCK_BACK_NS, ArmClient
from .camera_input import CameraInput
from .core.follower_behaviour import Follower, FollowerChoice
from .core.follower_rounds import FollowerPhase, FollowerRounds, HeardGuidance
from .core.perception_check import PerceptionCheck
from .core.rearrangement import FOLLOWER, LEADER, RearrangementModel
from .core.sessions import FollowedLeader
from .core.settings import FOLLOWER_SETTINGS, FollowerExecutorSettings
from .ros_conversions import FOLLOWER_REPORT, GUIDANCE, action_from_msg, counts_from_msg, move_msg, \
    pick_and_place_goal


class FollowerExecutor(Node):
    def __init__(self, node_name: str = 'follower_executor', **node_options):
        super().__init__(node_name, **node_options)
        params = self.params = NodeParameters(self)
        self.names = RobotNode(self, params)
        values = params.declare_schema(FOLLOWER_SETTINGS, on_change={
            'settle_time': self._set_settle_time, 'perception_fault_after': self._set_perception_fault_after})
        settings = self.settings = FollowerExecutorSettings.from_values(values)
        self.task = settings.task
        self.exit_when_done = settings.exit_when_done
        self.model = RearrangementModel(self.task)
        self.rounds = FollowerRounds(Follower(self.model, settings.follower, seed=settings.seed), self)
        self._set_settle_time(settings.settle_time)
        self.perception = PerceptionCheck(values['perception_fault_after'])
        self.look_again = None           # sim time of the next look while frames are rejected
        self.fault_round = None          # the round a perception fault was logged for
        self.camera = CameraInput(self, self.task, self.names.team(settings.camera), settings.image_transport,
                                  params=params)
        self.arm = ArmClient(self, params)
        self.session = new_session()
        self.leader = FollowedLeader(self.names.team(values['leader']), values['max_round_jump'])
        self.clock_seen = None           # the newest time of the node's clock seen: going back = a restart
        self.report_pub = self.create_publisher(FollowerReport, self.names.team(FOLLOWER_REPORT), RELIABLE)
        self.inputs = InputGuard.of(self)
        self.inputs.subscribe(Guidance, self.names.team(GUIDANCE), self._on_guidance, RELIABLE)
        self.finished = Future()
        self.estimate = None      # the camera estimate of the round being executed
        self.create_timer(0.05, self._tick)
        follower = settings.follower
        self.get_logger().info(f'arm {self.names.robot}, behaviour {follower.behaviour}'
                               + (f', deviation p={follower.deviation_probability}, rounds '
                                  f'{list(follower.deviation_rounds)}' if follower.behaviour == 'random' else '')
                               + f'; session {self.session:#x}, follows {self.leader.leader}')

    def _set_settle_time(self, value: float) -> None:
        self.settle = Duration(seconds=float(value))

    def _set_perception_fault_after(self, value: float) -> None:
        self.perception.fault_after = float(value)

    # --- events for the core's rounds ------------------------------------------------
    def _on_guidance(self, msg: Guidance) -> None:
        final = bool(msg.task_complete or msg.status)
        try:
            stamp = self.inputs.stamp(msg.header.stamp)
            if not final:
                round_state = counts_from_msg(self.task, msg.state)
                leader_action = action_from_msg(self.model, LEADER, msg.leader_move, 'leader_move')
                recommended = action_from_msg(self.model, FOLLOWER, msg.recommended_follower_move,
                                              'recommended_follower_move')
        except ValueError as error:   # counted and logged once per kind by the guard
            raise MalformedInput(f'dropped malformed guidance for round {msg.round}: {error}',
                                 kind=error_kind(error)) from None
        # Not from the current session of his leader: MalformedInput, counted and logged by the guard.
        followed = self.leader.check(msg.sender, msg.session, msg.round, final)
        if followed.new_session:
            self._session_changed(followed, msg.round)
        if final:
            self.get_logger().info(f'the leader ended the task: {msg.status or "goal reached"}')
            self.rounds.task_ended()
            if not self.finished.done():
                self.finished.set_result(True)
            return
        # Settling counts from the guidance's stamp when the frame is checked (a settle_time set meanwhile
        # applies to this round too); a stamp ahead of his clock (a clock that went back) counts from now.
        stamp = min(stamp, self.get_clock().now())
        self.rounds.guidance_heard(HeardGuidance(msg.round, stamp, round_state, leader_action, recommended,
                                                 msg.session))

    def _session_changed(self, followed: Followed, round_number: int) -> None:
        if followed.replaced is None:
            self.get_logger().info(f'following the leader\'s session {followed.session:#x} from round {round_number}')
        else:
            self.get_logger().warning(f'the leader\'s session changed ({followed.replaced:#x} -> '
                                      f'{followed.session:#x}, a restarted leader): rounds count from {round_number}')
        self.rounds.session_changed()
        self.look_again = None

    def _clock_went_back(self) -> bool:
        now = self.get_clock().now()
        back = self.clock_seen is not None and now.nanoseconds < self.clock_seen.nanoseconds - CLOCK_BACK_NS
        if back:
            self.get_logger().warning(f'the clock went back ({self.clock_seen.nanoseconds / 1e9:.1f} s -> '
                                      f'{now.nanoseconds / 1e9:.1f} s: a restarted simulation); settling anew')
            self.rounds.clock_went_back(now)
            self.camera.forget_frames()
            self.arm.abandon('the simulation restarted (the clock went back)')
            self.look_again = None
        self.clock_seen = now
        return back

    def _tick(self) -> None:
        self._clock_went_back()
        if self.rounds.phase is not FollowerPhase.SETTLING:
            return
        settled = self.rounds.pending.stamp + self.settle
        if self.look_again is not None and self.look_again > settled:
            settled = self.look_again                       # a newer frame than the one rejected
        stamp = self.camera.frame_time(not_before=settled)   # on demand: asks for a frame once settled
        if stamp is None or stamp < settled or not self.arm.server_is_ready():
            return
        try:
            estimate = self.camera.estimate()
        except ValueError as error:
            self.get_logger().warn(f'cannot use the camera frame: {error}', throttle_duration_sec=5.0)
            return
        number = self.rounds.pending.round
        verdict = self.perception.judge(estimate, len(self.camera.cube_labels), stamp.nanoseconds * 1e-9)
        if not verdict.accepted:
            self.look_again = Time(nanoseconds=int(verdict.retry_at * 1e9), clock_type=self.get_clock().clock_type)
            if verdict.fault and self.fault_round != number:
                self.fault_round = number
                self.get_logger().error(f'round {number}: perception fault: no usable camera frame for '
                                        f'{verdict.rejected_for:.1f} s ({verdict.reason}); still looking')
            else:
                self.get_logger().warn(f'camera frame rejected, not used as the table state: {verdict.reason}; '
                                       'looking again', throttle_duration_sec=5.0)
            return
        self.look_again = None
        self.estimate = estimate
        choice = self.rounds.table_seen(self.model.state_of(estimate.counts))
        self.get_logger().info(f'round {number}: {self.model.describe(FOLLOWER, choice.action)} ({choice.reason})')

    # --- the core's effects ----------------------------------------------------------
    def execute(self, round_number: int, choice: FollowerChoice) -> None:
        try:
            goal = pick_and_place_goal(self.model, FOLLOWER, choice.action, self.estimate)
        except ValueError as error:
            self.rounds.move_done(False, f'{error}: no effect')
            return
        self.arm.send(goal, self.rounds.move_done)

    def report(self, round_number: int, choice: FollowerChoice, succeeded: bool, message: str,
               leader_session: int = 0) -> None:
        report = FollowerReport(sender=self.get_fully_qualified_name(), session=self.session,
                                leader_session=leader_session, round=round_number,
                                behaviour=self.settings.follower.behaviour,
                                move=move_msg(self.model, FOLLOWER, choice.action), deviated=choice.deviated,
                                succeeded=succeeded, message=message)
        report.header.stamp = self.get_clock().now().to_msg()
        self.report_pub.publish(report)


def main(args=None) -> int:
    return run(FollowerExecutor, 'follower_executor', args)


if __name__ == '__main__':
    sys.exit(main())

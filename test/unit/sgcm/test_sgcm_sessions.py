"""Sessions of the SGCM nodes without ROS (issue 16 items 4, 5): which guidance the follower follows (a
restarted leader, a restarted follower, forged senders, rounds and task ends), which reports the leader
takes, the follower's rounds across a session change, a recording's rounds in the order played, and when
an arm goal is given up."""
from types import SimpleNamespace

import pytest

from collab_tools.core.input_checks import MalformedInput
from collab_tools.core.session_following import new_session
from sgcm.core.arm_goal import GoalWatch
from sgcm.core.follower_behaviour import Follower, FollowerSettings
from sgcm.core.follower_rounds import FollowerPhase, FollowerRounds, HeardGuidance
from sgcm.core.rearrangement import EMPTY, FOLLOWER
from sgcm.core.round_log import rounds_in_order
from sgcm.core.sessions import FollowedLeader, FollowerReports

LEADER = '/leader_arm/leader_planner'
OLD, NEW, FORGED = 0x1111, 0x2222, 0x3333
TOP = 2**32 - 1


def refused(leader, *args, kind):
    with pytest.raises(MalformedInput) as error:
        leader.check(*args)
    assert error.value.kind == kind, str(error.value)


def following(session=OLD, rounds=3):
    leader = FollowedLeader(LEADER, max_round_jump=3)
    for number in range(1, rounds + 1):
        leader.check(LEADER, session, number)
    return leader


def test_session_ids_are_random_non_zero_64_bit():
    ids = {new_session() for _ in range(1000)}
    assert len(ids) == 1000 and all(0 < s < 2**64 for s in ids)


def test_rounds_in_a_session_are_taken_once_in_order_and_not_far_ahead():
    leader = following(rounds=2)
    refused(leader, LEADER, OLD, 2, kind='guidance.round: already heard')
    refused(leader, LEADER, OLD, 1, kind='guidance.round: already heard')
    refused(leader, LEADER, OLD, TOP, kind='guidance.round: too far ahead')   # cannot silence him
    refused(leader, LEADER, OLD, 6, kind='guidance.round: too far ahead')
    assert leader.check(LEADER, OLD, 5).new_session is False                   # 2 lost rounds: still taken
    assert leader.check(LEADER, OLD, 6) and leader.last_round == 6


def test_other_senders_and_no_session_are_refused():
    leader = following()
    refused(leader, '/someone/else', OLD, 4, kind='guidance.sender: not the leader')
    refused(leader, LEADER, 0, 4, kind='guidance.session: none')
    assert leader.check(LEADER, OLD, 4)


def test_a_restarted_leader_is_followed_from_her_round_1_and_her_old_session_ends():
    leader = following(OLD, rounds=5)
    verdict = leader.check(LEADER, NEW, 1)
    assert (verdict.new_session, verdict.replaced, leader.last_round) == (True, OLD, 1)
    assert leader.check(LEADER, NEW, 2).new_session is False                   # confirmed: OLD has ended
    refused(leader, LEADER, OLD, 6, kind='guidance.session: ended')
    refused(leader, LEADER, OLD, 6, True, kind='guidance.session: ended')       # nor can it end the task


def test_a_forged_session_cannot_take_a_confirmed_follower_with_a_late_or_absurd_round():
    leader = following(OLD, rounds=3)
    refused(leader, LEADER, FORGED, TOP, kind='guidance.session: another, out of order')
    refused(leader, LEADER, FORGED, 9, kind='guidance.session: another, out of order')
    assert leader.check(LEADER, OLD, 4) and leader.session == OLD


def test_a_forged_restart_is_undone_by_the_real_leaders_next_round():
    leader = following(OLD, rounds=3)
    assert leader.check(LEADER, FORGED, 1).new_session               # looks like a restart: followed
    verdict = leader.check(LEADER, OLD, 4)                            # but the old session goes on
    assert verdict.new_session and leader.session == OLD
    leader.check(LEADER, OLD, 5)
    refused(leader, LEADER, FORGED, 2, kind='guidance.session: ended')


def test_a_restarted_follower_joins_the_session_under_way_and_one_forged_round_cannot_hold_him():
    leader = FollowedLeader(LEADER, max_round_jump=3)
    assert leader.check(LEADER, FORGED, TOP).new_session              # the first thing he hears
    assert leader.check(LEADER, OLD, 12).replaced == FORGED           # the real session under way takes him
    leader.check(LEADER, OLD, 13)
    refused(leader, LEADER, FORGED, TOP, kind='guidance.session: ended')


def test_the_task_ends_only_in_the_followed_session():
    leader = following(OLD, rounds=3)
    refused(leader, LEADER, FORGED, 0, True, kind='guidance.session: task end of another session')
    refused(leader, LEADER, FORGED, 3, True, kind='guidance.session: task end of another session')
    refused(leader, '/forger', OLD, 3, True, kind='guidance.sender: not the leader')
    refused(leader, LEADER, OLD, 2, True, kind='guidance.round: already heard')
    refused(FollowedLeader(LEADER), LEADER, OLD, 0, True, kind='guidance.session: task end of another session')
    assert leader.check(LEADER, OLD, 3, True).new_session is False     # the end repeats the last round


def test_the_leader_takes_reports_of_her_follower_to_her_session_and_notes_his_restart():
    reports = FollowerReports('/follower_arm/follower_executor', leader_session=NEW)
    with pytest.raises(MalformedInput, match='not the follower'):
        reports.check('/forger', 5, NEW)
    with pytest.raises(MalformedInput) as error:
        reports.check('/follower_arm/follower_executor', 5, OLD)       # to her previous life
    assert error.value.kind == 'follower_report.leader_session: not this leader'
    with pytest.raises(MalformedInput, match='no session'):
        reports.check('/follower_arm/follower_executor', 0, NEW)
    assert reports.check('/follower_arm/follower_executor', 5, NEW) is None
    assert reports.check('/follower_arm/follower_executor', 5, NEW) is None
    assert reports.check('/follower_arm/follower_executor', 6, NEW) == 5    # he restarted


class Port:
    def __init__(self):
        self.effects = []

    def execute(self, number, choice):
        self.effects.append(('execute', number))

    def report(self, number, choice, succeeded, message, leader_session=0):
        self.effects.append(('report', number, leader_session, succeeded))


def test_follower_rounds_restart_with_a_new_leader_session(model, cases):
    port = Port()
    rounds = FollowerRounds(Follower(model, FollowerSettings('obedient')), port)
    state = model.state_of(cases[0])
    move = int(model.feasible(state, FOLLOWER)[1])
    for number in (1, 2):
        rounds.guidance_heard(HeardGuidance(number, float(number), state, EMPTY, EMPTY, OLD))
        rounds.table_seen(state)
    rounds.guidance_heard(HeardGuidance(3, 3.0, state, EMPTY, move, OLD))
    rounds.table_seen(state)
    assert rounds.phase is FollowerPhase.EXECUTING
    rounds.guidance_heard(HeardGuidance(4, 4.0, state, EMPTY, EMPTY, OLD))   # pending when she restarts
    rounds.session_changed()
    assert rounds.pending is None and rounds.last_round == 0
    assert rounds.guidance_heard(HeardGuidance(1, 0.5, state, EMPTY, EMPTY, NEW))   # her round 1 is not "old"
    rounds.move_done(False, 'given up: the arm\'s action server left the graph')
    assert port.effects[-1] == ('report', 3, OLD, False)        # his move is reported to the session it was for
    rounds.clock_went_back(0.1)                                  # the restarted simulation's clock
    assert rounds.pending.stamp == 0.1
    rounds.table_seen(state)
    assert port.effects[-1] == ('report', 1, NEW, True)


def msg(**fields):
    return SimpleNamespace(**{'task_complete': False, 'status': '', 'sender': LEADER, **fields})


def test_a_recordings_rounds_in_the_order_played_across_a_restart():
    guidance = [msg(session=OLD, round=1), msg(session=OLD, round=2), msg(session=NEW, round=1),
                msg(session=FORGED, round=1, sender='/forger'), msg(session=NEW, round=2),
                msg(session=NEW, round=2, task_complete=True)]
    reports = [SimpleNamespace(leader_session=s, round=r) for s, r in ((OLD, 1), (NEW, 1), (NEW, 2))]
    played, final = rounds_in_order(guidance, reports)
    assert final is guidance[-1]
    assert [(g.session, g.round) for g, _ in played] == [(OLD, 1), (OLD, 2), (NEW, 1), (NEW, 2)]
    assert [r and (r.leader_session, r.round) for _, r in played] == [(OLD, 1), None, (NEW, 1), (NEW, 2)]
    # A recording from before sessions: one session, as before.
    old = [SimpleNamespace(round=n, task_complete=False, status='') for n in (2, 1)]
    assert [g.round for g, _ in rounds_in_order(old, [])[0]] == [1, 2]


def test_a_goal_is_given_up_on_timeout_or_server_loss_and_its_late_result_ignored():
    watch = GoalWatch(timeout=60.0, server_lost_after=5.0)
    token = watch.sent(now=0.0)
    assert watch.check(10.0, server_ready=True) is None
    assert watch.check(11.0, server_ready=False) is None       # gone for a moment
    assert watch.check(12.0, server_ready=True) is None
    assert watch.check(20.0, server_ready=False) is None
    assert 'left the graph' in watch.check(25.0, server_ready=False)
    assert not watch.busy and not watch.finished(token)         # its late result changes nothing
    token = watch.sent(now=100.0)
    assert watch.check(159.0, True) is None and 'no result within 60 s' in watch.check(160.0, True)
    token = watch.sent(now=200.0)
    assert watch.finished(token) and watch.check(1000.0, False) is None and watch.given_up == 2
    token = watch.sent(now=300.0)                                # the simulation restarted meanwhile
    assert watch.give_up() and not watch.give_up() and not watch.finished(token) and watch.given_up == 3


def test_a_goal_is_given_up_when_a_new_action_server_instance_appears():
    watch = GoalWatch(timeout=60.0, server_lost_after=5.0)
    watch.sent(now=0.0, servers=frozenset({b'old'}))
    assert watch.check(1.0, True, frozenset({b'old'})) is None
    # The bridge was killed and restarted at once: the old endpoint is still listed (DDS lease), the new
    # one is there too; its server never heard of the goal.
    reason = watch.check(2.0, True, frozenset({b'old', b'new'}))
    assert 'new instance' in reason and not watch.busy and watch.given_up == 1
    # The old one gone and a new one there by the next check: the same.
    watch.sent(now=10.0, servers=frozenset({b'old'}))
    assert 'new instance' in watch.check(11.0, True, frozenset({b'new'}))
    # Only the old one gone: server loss after server_lost_after, as before.
    watch.sent(now=20.0, servers=frozenset({b'old'}))
    assert watch.check(21.0, False, frozenset()) is None and 'left the graph' in watch.check(26.0, False, frozenset())
    # Endpoints not known when sent (the graph lagged): no instance check, the other bounds hold.
    watch.sent(now=30.0)
    assert watch.check(31.0, True, frozenset({b'new'})) is None

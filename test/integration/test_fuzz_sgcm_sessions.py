"""Forged identities and rounds against the SGCM leader and follower (issue 16 item 4).

While the arms play case_3 (4 rounds undisturbed), once the follower has heard two rounds of the
leader's session, the test publishes guidance from another sender (a round, a task-complete), a
task-complete of another session, a round 2^32-1 of the leader's own session (a flood of them),
rounds of another session and of no session; and reports to the leader from another sender, to
another leader session and with no session. Both nodes drop each, count it and log each kind once;
the follower is not silenced (he reports every round of the leader) and not stopped (he ends with
the leader's real task end), and the task completes at the goal in the undisturbed number of rounds
give or take two.
"""

import time

import pytest
from sgcm_interfaces.msg import FollowerReport, Guidance, Move

from fuzz_helpers import assert_rejected_once_per_kind, flood, publish_all
from test_sgcm_nodes import FOLLOWER_NS, LEADER_NS, resume_once_heard, start_case

LEADER = f'{LEADER_NS}/leader_planner'
FOLLOWER = f'{FOLLOWER_NS}/follower_executor'
FORGED_SESSION = 0xF0F0F0F0F0F0F0F0
TOP_ROUND = 2**32 - 1
UNDISTURBED_ROUNDS = 4      # case_3 (sgcm.core.episode.run_sgcm with the task's horizon)


@pytest.fixture
def task_file(config_dir):
    return config_dir / 'sgcm' / 'task.yaml'


def forged(real: Guidance, **fields) -> Guidance:
    """A well-formed guidance like ``real`` (its state, its stamp, no moves) with ``fields`` changed."""
    values = dict(sender=real.sender, session=real.session, round=real.round, horizon=real.horizon,
                  strategy=real.strategy, state=real.state, leader_move=Move(empty=True),
                  leader_move_succeeded=True, recommended_follower_move=Move(empty=True))
    values.update(fields)
    msg = Guidance(**values)
    msg.header.stamp = real.header.stamp
    return msg


def test_forged_senders_sessions_and_rounds_are_refused_and_the_task_completes(session, ros_node, tmp_path,
                                                                              task_file, config_dir):
    heard, reports = [], []
    subscription = ros_node.create_subscription(Guidance, '/sgcm/guidance', heard.append, 10)
    ros_node.create_subscription(FollowerReport, '/sgcm/follower_report', reports.append, 10)
    start_case(session, tmp_path, task_file, config_dir, 'case_3', start_paused=True)
    session.wait_for_nodes([LEADER, FOLLOWER], 60.0)
    resume_once_heard(session, subscription)
    deadline = time.monotonic() + 120.0
    while len([g for g in heard if g.sender == LEADER and not g.status]) < 2:   # he follows, confirmed
        assert time.monotonic() < deadline, f'the leader announced no second round: {heard}'
        session.check_alive()
        time.sleep(0.05)
    real = heard[-1]
    assert real.session != 0 and real.round == 2
    time.sleep(0.3)   # the follower has it too (reliable; our copy came first or at once)

    follower_input = [
        forged(real, sender='/intruder/leader_planner', round=3),                       # another sender
        forged(real, sender='/intruder/leader_planner', task_complete=True, status=''),  # its task end
        forged(real, session=FORGED_SESSION, round=0, task_complete=True),               # another session's end
        forged(real, session=FORGED_SESSION, round=7),                                   # another session's round
        forged(real, session=FORGED_SESSION, round=TOP_ROUND),
        forged(real, session=0, round=3),                                                # no session
        forged(real, round=TOP_ROUND),                                                   # her session, far ahead
    ]
    publisher = publish_all(ros_node, Guidance, '/sgcm/guidance', follower_input, subscribers=2)
    flood(publisher, forged(real, round=TOP_ROUND), 30, seconds=0.5)
    report = dict(round=real.round, behaviour='obedient', move=Move(empty=True), succeeded=True)
    leader_input = [
        FollowerReport(sender='/intruder/follower_executor', session=5, leader_session=real.session, **report),
        FollowerReport(sender=FOLLOWER, session=5, leader_session=FORGED_SESSION, **report),
        FollowerReport(sender=FOLLOWER, session=0, leader_session=real.session, **report),
    ]
    for msg in leader_input:
        msg.header.stamp = real.header.stamp
    publish_all(ros_node, FollowerReport, '/sgcm/follower_report', leader_input, subscribers=2)
    session.check_alive()

    deadline = time.monotonic() + 240.0
    # Hers: her name, her session and a round below the forged 2^32-1 (the test hears its own messages too).
    played = lambda: [g for g in heard if g.sender == LEADER and g.session == real.session and g.round < 1000]  # noqa: E731
    while not (finals := [g for g in played() if g.task_complete or g.status]):
        assert time.monotonic() < deadline, 'the task did not end within 240 s'
        session.check_alive()
        time.sleep(0.1)
    final = finals[0]
    assert final.task_complete and final.status == 'goal reached', final.status
    assert session.wait_for_exit('leader_arm/leader_planner', 30) == 0
    assert session.wait_for_exit('follower_arm/follower_executor', 30) == 0
    rounds = [g.round for g in played() if not (g.task_complete or g.status)]
    assert rounds == list(range(1, len(rounds) + 1)) and len(rounds) <= UNDISTURBED_ROUNDS + 2, rounds
    # Not silenced: he reported every round of her session, from his own node.
    answered = {r.round for r in reports if r.sender == FOLLOWER and r.leader_session == real.session}
    assert answered >= set(rounds), (rounds, sorted(answered))

    follower = (session.run_dir / 'logs' / 'follower_arm' / 'follower_executor.log').read_text()
    assert_rejected_once_per_kind(follower, '/sgcm/guidance', [
        'guidance.sender: not the leader', 'guidance.session: task end of another session',
        'guidance.session: another, out of order', 'guidance.session: none', 'guidance.round: too far ahead'])
    assert '/sgcm/guidance: 10 malformed messages dropped so far [guidance.round: too far ahead]' in follower
    assert follower.count('the leader ended the task') == 1 and 'Traceback' not in follower
    leader = (session.run_dir / 'logs' / 'leader_arm' / 'leader_planner.log').read_text()
    assert_rejected_once_per_kind(leader, '/sgcm/follower_report', [
        'follower_report.sender: not the follower', 'follower_report.leader_session: not this leader',
        'follower_report.session: none'])
    assert 'Traceback' not in leader

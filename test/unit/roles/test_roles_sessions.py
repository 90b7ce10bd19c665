"""Sessions and senders on the role topics (core.sessions, issue 16 item 4), the player following a restarted
engine and the engine re-including a player that is back (core.player, core.engine), without ROS."""
import pytest

from collab_tools.core.input_checks import MalformedInput, error_kind
from collab_tools.core.session_following import new_session
from role_engine.core.engine import MAX_REJOINS, EnginePhase
from role_engine.core.player import PlayerState, RoundAssignment
from role_engine.core.sessions import (MAX_ROUND_JUMP, SessionFollower, Verdict, check_announcement_sender,
                                       engine_channel_verdict, node_of_robot)

from test_roles_player_engine import a_role, engine, player, view  # noqa: F401 (player: a fixture)

ENGINE = '/role_engine'
PLAYER_1 = '/burger_1/role_player'
PLAYER_2 = '/burger_2/role_player'


def refused(kind, call, *args):
    with pytest.raises(MalformedInput) as raised:
        call(*args)
    assert error_kind(raised.value) == kind, raised.value
    return str(raised.value)


def following(session=11, round_=3):
    follower = SessionFollower(ENGINE)
    assert follower.check_assignment(ENGINE, session, round_) is Verdict.APPLY
    assert follower.follow(session, round_)
    return follower


def test_session_ids_are_random_non_zero_uint64():
    ids = {new_session() for _ in range(200)}
    assert len(ids) == 200 and all(0 < s < 2**64 for s in ids)


def test_node_of_robot_is_a_node_in_the_robots_namespace():
    assert node_of_robot('/burger_1/role_player', 'burger_1')
    assert node_of_robot('/sim1/burger_1/role_player', 'burger_1')
    assert not node_of_robot('/burger_2/role_player', 'burger_1')
    assert not node_of_robot('/role_engine', 'role_engine')
    assert not node_of_robot('burger_1/role_player', 'burger_1')       # not a full name
    assert not node_of_robot('/burger_1/', 'burger_1') and not node_of_robot('', '')


def test_a_later_round_of_the_session_applies_an_older_one_is_dropped_quietly():
    follower = following(round_=3)
    assert follower.check_assignment(ENGINE, 11, 3) is Verdict.OLD
    assert follower.check_assignment(ENGINE, 11, 1) is Verdict.OLD
    assert follower.check_assignment(ENGINE, 11, 5) is Verdict.APPLY          # rounds may be missed
    assert not follower.follow(11, 5) and (follower.session, follower.round) == (11, 5)


def test_a_restarted_engines_round_one_is_applied_and_the_old_session_is_left_for_good():
    follower = following(session=11, round_=5)
    assert follower.check_assignment(ENGINE, 22, 1) is Verdict.APPLY          # round 1 < 5, a new session
    assert follower.follow(22, 1)
    text = refused('old session', follower.check_assignment, ENGINE, 11, 6)     # the old engine is not followed back
    assert 'session 11' in text and 'session 22' in text
    assert follower.check_assignment(ENGINE, 22, 2) is Verdict.APPLY


def test_round_2_to_the_32_minus_1_cannot_silence_a_player():
    follower = following(round_=3)
    refused('round jump', follower.check_assignment, ENGINE, 11, 2**32 - 1)
    refused('round jump', follower.check_assignment, ENGINE, 11, 3 + MAX_ROUND_JUMP + 1)
    refused('round jump', follower.check_assignment, ENGINE, 99, 2**32 - 1)     # as a new session's first round
    refused('round jump', follower.check_assignment, ENGINE, 99, 0)
    assert (follower.session, follower.round) == (11, 3)                      # nothing changed
    assert follower.check_assignment(ENGINE, 11, 4) is Verdict.APPLY          # the engine's next round still applies
    assert follower.check_assignment(ENGINE, 11, 3 + MAX_ROUND_JUMP) is Verdict.APPLY
    fresh = SessionFollower(ENGINE)                                           # a player that has no session yet
    refused('round jump', fresh.check_assignment, ENGINE, 11, 2**32 - 1)
    assert fresh.check_assignment(ENGINE, 11, MAX_ROUND_JUMP) is Verdict.APPLY


def test_other_senders_and_session_zero_are_refused():
    follower = following()
    assert 'not the role engine /role_engine' in refused('other sender', follower.check_assignment,
                                                         '/evil/role_engine', 11, 4)
    refused('other sender', follower.check_assignment, '', 11, 4)
    text = refused('other sender', follower.check_assignment, 'x' * 10_000, 11, 4)
    assert len(text) < 200                                                     # a forged name is not echoed whole
    refused('no session', follower.check_assignment, ENGINE, 0, 1)


def test_channel_roles_of_the_current_session_from_the_robots_node_or_the_engine():
    follower = SessionFollower(ENGINE)
    assert not follower.channel_verdict(PLAYER_2, 11, 'burger_2', 1)            # no session yet: quietly dropped
    follower.follow(11, 2)
    assert follower.channel_verdict(PLAYER_2, 11, 'burger_2', 2)
    assert follower.channel_verdict(ENGINE, 11, 'burger_2', 2)                  # an initial role
    assert not follower.channel_verdict(PLAYER_2, 11, 'burger_2', 1)            # an earlier round: quietly
    refused('forged sender', follower.channel_verdict, PLAYER_2, 11, 'pioneer_1', 2)
    refused('forged sender', follower.channel_verdict, PLAYER_1, 11, 'burger_2', 2)   # burger_1's name on burger_2's
    refused('forged sender', follower.channel_verdict, '/evil', 11, 'burger_2', 2)
    refused('other session', follower.channel_verdict, PLAYER_2, 12, 'burger_2', 2)


def test_the_engine_takes_roles_of_its_session_from_the_robots_node():
    assert not engine_channel_verdict(ENGINE, 11, ENGINE, 11, 'burger_1')        # its own initial role
    assert engine_channel_verdict(ENGINE, 11, PLAYER_1, 11, 'burger_1')
    refused('forged sender', engine_channel_verdict, ENGINE, 11, PLAYER_2, 11, 'burger_1')
    refused('forged sender', engine_channel_verdict, ENGINE, 11, '/other/role_engine', 11, 'burger_1')
    refused('other session', engine_channel_verdict, ENGINE, 11, PLAYER_1, 10, 'burger_1')
    check_announcement_sender(PLAYER_1, 'burger_1')
    refused('forged sender', check_announcement_sender, PLAYER_2, 'burger_1')


# --- the behaviours -----------------------------------------------------------------------------
def roles():
    return {'burger_1': ('diamond_0', a_role('burger_1', (0.0, 0.0), (1.0, 0.0))),
            'burger_2': ('diamond_1', a_role('burger_2', (0.0, 1.0), (-1.0, 1.0)))}


def test_a_player_applies_a_new_sessions_round_one_after_round_five(player):  # noqa: F811
    player, port = player
    player.on_assignment(RoundAssignment(5, 'assigned', 'x', roles(), session=11))
    player.on_assignment(RoundAssignment(4, 'aborted', 'x', {}, session=11))    # older round, same session
    assert player.round == 5 and player.state is PlayerState.WAITING
    player.on_assignment(RoundAssignment(1, 'aborted', 'restarted engine', {}, session=22))
    assert (player.session, player.round) == (22, 1) and player.state is PlayerState.IDLE
    player.on_assignment(RoundAssignment(2, 'assigned', 'x', roles(), session=22))
    assert player.role_id == 'diamond_0' and player.replan(1.0) is None
    assert (port.published[-1].session, port.published[-1].round) == (22, 2)


def silence(behaviour, port, team, robot='burger_2'):
    """Every robot of the last round but ``robot`` is heard; then the silence check runs."""
    first = port.rounds[-1]
    after = first.roles[0].role.start_time + behaviour.tuning.problems.silence_timeout + 0.5
    for r in first.roles:
        if r.robot != robot:
            behaviour.heard(r.robot, after - 0.1, r.role, r.role_id, arrived=False)
    behaviour.tick(after, view(team, after))
    return after


def test_a_silent_robot_whose_player_is_back_is_re_included():
    behaviour, port, team = engine(min_robots=3)
    assert not behaviour.announced('burger_2')                                  # not excluded: nothing to do
    behaviour.tick(0.0, view(team))
    now = silence(behaviour, port, team)
    second = port.rounds[-1]
    assert second.round == 2 and 'burger_2' not in [r.robot for r in second.roles]
    assert behaviour.announced('burger_2')
    assert behaviour.excluded == [] and behaviour.phase is EnginePhase.NEGOTIATE
    behaviour.tick(now + 1.0, view(team, now + 1.0))
    third = port.rounds[-1]
    assert third.round == 3 and third.status == 'assigned' and third.message == 'burger_2 is back'
    assert sorted(r.robot for r in third.roles) == sorted(m.name for m in team)
    assert not behaviour.announced('burger_2')                                  # in the round again


def test_a_robot_rejoins_at_most_max_rejoins_times_and_a_stuck_one_stays_out():
    behaviour, port, team = engine(min_robots=3)
    behaviour.tick(0.0, view(team))
    for _ in range(MAX_REJOINS):
        now = silence(behaviour, port, team)
        assert behaviour.announced('burger_2')
        behaviour.tick(now + 1.0, view(team, now + 1.0))
    silence(behaviour, port, team)
    assert not behaviour.announced('burger_2') and behaviour.excluded == ['burger_2']
    assert 'stays excluded' in port.lines[-1][1]
    behaviour.excluded.append('pioneer_1')                                     # excluded, but not as silent
    assert not behaviour.announced('pioneer_1')


def test_a_recordings_final_round_is_the_last_sessions_highest():
    from role_engine.experiments.formation_bag import AssignmentRecord, final_assignment

    def record(session, round_):
        return AssignmentRecord(float(round_), round_, 'assigned', '', {}, {}, [], None, session)

    # the first engine reached round 3, the restarted one counts 1, 2 again: its round 2 is the final one
    assert final_assignment([record(11, 1), record(11, 3), record(22, 1), record(22, 2)]) == record(22, 2)
    assert final_assignment([record(0, 1), record(0, 2)]) == record(0, 2)      # a recording before sessions
    assert final_assignment([]) is None


def test_a_player_standing_on_its_destination_keeps_its_role_and_arrives_when_it_ends(player):  # noqa: F811
    """A renegotiation can hand a robot the point it stands on: its role barely moves; re-planning it would
    restart it every period, and the robot would never arrive."""
    player, port = player
    still = a_role('burger_1', (1.0, 0.02), (1.0, 0.0), start_time=2.0, total_time=6.0)
    player.on_assignment(RoundAssignment(1, 'assigned', 'x', {'burger_1': ('diamond_0', still)}, session=11))
    for now in (3.0, 4.0, 5.0, 6.0, 7.0):
        player.observe(now, (1.0, 0.02, 0.0))
        assert player.replan(now) is None and player.role is still               # kept: only the heartbeat
        player.control(now)
    player.observe(8.5, (1.0, 0.02, 0.0))
    player.control(8.5)
    assert player.state is PlayerState.ARRIVED and port.published[-1].arrived


def test_the_markers_drop_the_roles_of_a_session_that_is_over():
    from types import SimpleNamespace as Msg
    from role_engine.core.markers import RoleMarkers

    def role(robot, round_, session, version=1):
        return Msg(robot=robot, role_id='r', round=round_, version=version, session=session, start_time=0.0,
                   dt=0.5, x=[0.0, 1.0], y=[0.0, 0.0])

    def assignment(round_, session, roles):
        return Msg(round=round_, session=session, status='assigned', message='', robots=[r.robot for r in roles],
                   role_ids=['r'] * len(roles), goal_x=[1.0] * len(roles), goal_y=[0.0] * len(roles),
                   initial_roles=roles)

    source = RoleMarkers()
    source.on_assignment(assignment(3, 11, [role('a', 3, 11), role('b', 3, 11)]))
    source.on_process_role(role('b', 3, 11, version=5))
    source.on_assignment(assignment(1, 22, [role('a', 1, 22)]))       # a restarted engine: round 1 < 3
    assert list(source.roles) == ['a'] and source.roles['a'].session == 22
    source.on_process_role(role('b', 3, 11, version=6))                # the old session's player: not drawn
    assert list(source.roles) == ['a']

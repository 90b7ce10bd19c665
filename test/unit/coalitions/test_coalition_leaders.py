"""Several leaders in one team (issue 13, item 3): a helper serves several coalitions where its
schemas can serve them at once (capability sharing) and refuses, with the reason, only what
conflicts; a leader keeps its own task while it helps. The rule (core.coalition_sharing), the
commitment ledger's admission, the search's solutions, the life cycles of a whole team on their
real channels (lifecycle_team, no ROS) and the bag check read from their statuses."""
from __future__ import annotations

import pytest

from coalition_agents.core import CoalitionSearch, StaticSensing
from coalition_agents.core.agent_state import AgentState
from coalition_agents.core.coalition_sharing import (
    AIMED_SENSOR, INFORMATION, MOTOR, OWN_TASK, SENSOR, CoalitionPart, Use, conflict, first_conflict, solution_parts,
    team_sharing,
)
from coalition_agents.core.transport.commitments import CommitmentLedger
from coalition_agents.experiments.coalition_bag import CoalitionRun, CommitmentRecord, StatusRecord, commitment_check

from lifecycle_team import Team, capability_text


def part(robot, coalition_id, leader, *uses):
    return CoalitionPart(robot, coalition_id, leader, frozenset(uses))


# --- the rule -------------------------------------------------------------------------------------------

def test_information_and_body_fixed_sensor_readings_are_shared():
    gps = Use(SENSOR, 'gps', 'F_G(h)')
    a = part('h', 'a/1', 'a', gps, Use(SENSOR, 'fiducial', 'F_R(a, h)'), Use(INFORMATION, 'F_G(a)'))
    b = part('h', 'b/1', 'b', gps, Use(SENSOR, 'fiducial', 'F_R(b, h)'), Use(INFORMATION, 'F_G(b)'))
    assert conflict(a, b) == '' and first_conflict([a], b) == ''


def test_one_motor_schema_at_a_time_and_an_aimed_sensor_on_one_referent():
    follow_a = part('h', 'a/1', 'a', Use(MOTOR, 'maintain_relative_position', 'a'))
    follow_b = part('h', 'b/1', 'b', Use(MOTOR, 'maintain_relative_position', 'b'))
    reason = conflict(follow_a, follow_b)
    assert 'h runs one motor schema at a time' in reason and 'coalition b/1 of b' in reason
    own = part('h', '', 'h', Use(MOTOR, 'navigate', OWN_TASK))
    assert 'its own task' in conflict(own, follow_b)
    # The same MS for the same leader is one activation; two coalitions of that leader cannot exist.
    assert conflict(follow_a, part('h', 'c/1', 'c', Use(MOTOR, 'maintain_relative_position', 'a'))) == ''
    camera_a = part('h', 'a/1', 'a', Use(AIMED_SENSOR, 'fiducial', 'F_R(a, h)'))
    camera_b = part('h', 'b/1', 'b', Use(AIMED_SENSOR, 'fiducial', 'F_R(b, h)'))
    assert 'cannot point two ways' in conflict(camera_a, camera_b)
    assert conflict(camera_a, part('h', 'b/1', 'b', Use(AIMED_SENSOR, 'fiducial', 'F_R(a, h)'))) == ''
    assert first_conflict([camera_a, follow_a], follow_b).startswith('h runs one motor schema')


def test_uses_as_text():
    for use in (Use(SENSOR, 'gps', 'F_G(robot_1)'), Use(MOTOR, 'navigate', OWN_TASK), Use(INFORMATION, 'F_M')):
        assert Use.parse(use.text) == use
    assert Use.parse('sensor:fiducial:F_R(a, b)').target == 'F_R(a, b)'
    with pytest.raises(ValueError, match='use.kind'):
        Use.parse('wheel:left')
    with pytest.raises(ValueError, match='kind:name'):
        Use.parse('motor')


def test_the_ledger_holds_what_its_admission_rule_admits():
    ledger = CommitmentLedger('h')
    assert ledger.hold('a/1', 'a', ('a', 'h'), 0.0) == (True, '')
    assert not ledger.hold('b/1', 'b', ('b', 'h'), 0.1)[0]          # no rule: one at a time (as before)
    seen = []

    def rule(held, coalition_id, leader, members):
        seen.append(([c.coalition_id for c in held], coalition_id))
        return 'busy with c' if leader == 'c' else ''
    ledger.admission = rule
    assert ledger.hold('b/1', 'b', ('b', 'h'), 0.2, 1.0) == (True, '')
    assert ledger.hold('c/1', 'c', ('c', 'h'), 0.3) == (False, 'busy with c')
    assert ledger.hold('b/1', 'b', ('b', 'h'), 0.4, 1.0) == (True, '')   # a renewal is not admitted again
    assert seen == [(['a/1'], 'b/1'), (['a/1', 'b/1'], 'c/1')]
    assert [c.coalition_id for c in ledger.held(0.5)] == ['a/1', 'b/1']
    assert ledger.release('a/1', 'a', 0.6) and ledger.holds('b/1', 'b', 0.6)
    assert ledger.held(1.5) == () and ledger.history[-1] == (1.5, 'expired', 'b/1')


# --- the search's coalitions: a column in which every robot but the front one navigates ---------------

def column_readings(n):
    names = [f'robot_{i}' for i in range(1, n + 1)]
    readings = {name: {'laser': [f'F_A({name})']} for name in names}
    readings['robot_1']['localization'] = ['F_G(robot_1)']
    for front, back in zip(names, names[1:]):
        readings[back]['fiducial'] = [f'F_R({front}, {back})']
    return names, readings


def test_the_search_finds_every_leaders_coalition_and_they_share(library, costs, tasks, fig7_types):
    names, readings = column_readings(4)
    team = {name: fig7_types['type2' if name == 'robot_1' else 'type1'] for name in names}
    search = CoalitionSearch(library, costs, tasks['navigation'], team, StaticSensing.from_text(readings, library,
                                                                                             names))
    results = search.run(names[1:])
    best = {robot: results[robot].best for robot in names[1:]}
    for index, robot in enumerate(names[1:], start=2):
        assert best[robot] is not None and sorted(best[robot].members) == names[:index]
    formation = team_sharing(solution_parts(best[robot], f'{robot}/1') for robot in names[1:])
    assert formation.conflicts == {}
    assert formation.shared == {'robot_1': ('robot_2/1', 'robot_3/1', 'robot_4/1'),
                                'robot_2': ('robot_2/1', 'robot_3/1', 'robot_4/1'),
                                'robot_3': ('robot_3/1', 'robot_4/1')}
    # robot_1 serves one GPS reading to all three; robot_2 one fiducial reading of robot_1.
    assert {use.text for use in formation.parts['robot_1'][2].uses} >= {'sensor:localization:F_G(robot_1)'}
    assert formation.to_dict()['robots_serving_several'] == 3
    # Driving, every robot runs one motor schema: its own task's or the helper MS for one leader.
    driving = team_sharing(solution_parts(best[robot], f'{robot}/1', 'navigate', 'maintain_relative_position')
                           for robot in names[1:])
    assert set(driving.conflicts) == {'robot_1', 'robot_2', 'robot_3'} and driving.shared == {}


# --- the life cycles of a team ------------------------------------------------------------------------

LOCALIZER = ('gps', 'fiducial', 'laser')
BLIND = ('fiducial', 'laser')


@pytest.fixture
def files(config_dir):
    return {'schemas_file': str(config_dir / 'schemas.yaml'), 'costs_file': str(config_dir / 'costs.yaml'),
            'tasks_file': str(config_dir / 'tasks.yaml')}


def column_team(files, n, **common):
    robots = {f'robot_{i}': ('localizer' if i == 1 else 'blind') for i in range(1, n + 1)}
    capabilities = capability_text({'localizer': LOCALIZER, 'blind': BLIND}, robots)
    poses = {robot: (-(i - 1) * 1.0, 0.0, 0.0) for i, robot in enumerate(robots, start=1)}
    sees = {f'robot_{i}': [f'robot_{i - 1}'] for i in range(2, n + 1)}
    tasks = {robot: 'none' if robot == 'robot_1' else 'navigation' for robot in robots}
    return Team(files, capabilities, tasks, poses, sees, search_time=3.0, settle_time=1.0, **common)


def bag_of(team):
    """The statuses the agents published, as the bag check reads them."""
    run = CoalitionRun()
    for robot, port in team.ports.items():
        for stamp, report in port.statuses:
            run.statuses.append(StatusRecord(
                stamp, robot, report.state, report.task, report.coalition_id, report.leader, report.members,
                report.cost, report.detail, commitments=tuple(CommitmentRecord(c.coalition_id, c.leader, c.members,
                                                                               c.uses) for c in report.commitments)))
    run.statuses.sort(key=lambda s: s.stamp)
    return run


def leaders_settled(team):
    return all(team.state(robot) in (AgentState.COMMITTED, AgentState.FAILED) for robot in team.robots[1:])


def test_a_column_in_which_every_robot_but_the_front_one_navigates(files):
    team = column_team(files, 4)
    end = team.run(0.1, 8.0, until=leaders_settled)
    for index, robot in enumerate(team.robots[1:], start=2):
        report = team.report(robot)
        assert report.state is AgentState.COMMITTED, report.detail
        assert sorted(report.members) == team.robots[:index] and report.leader == robot
    # Every helper keeps serving: the front robot three coalitions, robot_2 its own and two more.
    held = {robot: [c.coalition_id for c in team.report(robot).commitments] for robot in team.robots}
    own = {robot: team.report(robot).coalition_id for robot in team.robots[1:]}
    assert set(held['robot_1']) == set(own.values()) and len(held['robot_1']) == 3
    assert held['robot_2'][0] == own['robot_2'] and set(held['robot_2'][1:]) == {own['robot_3'], own['robot_4']}
    assert held['robot_3'] == [own['robot_3'], own['robot_4']] and held['robot_4'] == [own['robot_4']]
    assert team.report('robot_1').state is AgentState.COMMITTED
    assert not any('declined' in text for port in team.ports.values() for _, text in port.logs)
    # The helpers stream each value once per receiver, whatever number of coalitions they serve.
    assert not team.queue
    team.lives['robot_1'].on_stream_timer(end + 0.1)
    pairs = [(m.receiver, str(m.instance)) for m in team.queue]
    assert pairs and len(pairs) == len(set(pairs)) and ('robot_2', 'F_G(robot_1)') in pairs
    team.deliver()
    # The bag check: sharing, no conflict.
    check = commitment_check(bag_of(team))
    assert check['conflicting'] == {} and check['robots_serving_several'] == 3
    assert sorted(check['shared']) == ['robot_1', 'robot_2', 'robot_3'] and check['max_coalitions_per_robot'] == 3
    uses = next(c.uses for c in team.report('robot_1').commitments)
    assert 'sensor:gps:F_G(robot_1)' in uses


TWO_LEADERS = {'robot_a': 'navigation', 'robot_b': 'navigation', 'robot_h': 'none'}
#: robot_h localises and sees both blind leaders (they see nobody): both need it.
TWO_POSES = {'robot_a': (0.0, 1.0, 0.0), 'robot_b': (0.0, -1.0, 0.0), 'robot_h': (-1.5, 0.0, 0.0)}


def two_leaders(files, **values):
    capabilities = capability_text({'localizer': LOCALIZER, 'blind': BLIND},
                                   {'robot_a': 'blind', 'robot_b': 'blind', 'robot_h': 'localizer'})
    return Team(files, capabilities, TWO_LEADERS, TWO_POSES, {'robot_h': ['robot_a', 'robot_b']},
                values=values, search_time=3.0, settle_time=1.0, max_reforms=0)


def test_two_leaders_share_one_helper(files):
    team = two_leaders(files)
    team.run(0.1, 8.0, until=lambda t: all(t.state(r) is not AgentState.SEARCHING
                                           and t.state(r) is not AgentState.NEGOTIATING for r in ('robot_a', 'robot_b')))
    for leader in ('robot_a', 'robot_b'):
        assert team.report(leader).state is AgentState.COMMITTED, team.report(leader).detail
        assert team.report(leader).members == (leader, 'robot_h')
    helper = team.report('robot_h')
    assert helper.state is AgentState.COMMITTED and len(helper.commitments) == 2
    uses = {use for c in helper.commitments for use in c.uses}
    assert {'sensor:fiducial:F_R(robot_a, robot_h)', 'sensor:fiducial:F_R(robot_b, robot_h)'} <= uses
    # Released by one leader, it keeps serving the other.
    first = helper.commitments[0]
    team.channels[first.leader].release(first.coalition_id, 'task completed')
    team.deliver()
    helper = team.report('robot_h')
    assert helper.state is AgentState.COMMITTED and [c.coalition_id for c in helper.commitments] == [
        team.report('robot_b' if first.leader == 'robot_a' else 'robot_a').coalition_id]
    assert commitment_check(bag_of(team))['conflicting'] == {}


@pytest.mark.parametrize('values, refusal', [
    # both leaders need the helper's motor schema (it drives: maintain_relative_position on each)
    ({'robot_a': {'drive': True}, 'robot_b': {'drive': True}, 'robot_h': {'drive': True}},
     'robot_h runs one motor schema at a time'),
    # its fiducial must be aimed: at robot_a for one coalition, at robot_b for the other
    ({'robot_h': {'aimed_sensors': ['fiducial']}}, "robot_h's fiducial must be aimed at one referent"),
])
def test_a_helper_refuses_a_conflicting_coalition_with_the_reason(files, values, refusal):
    team = two_leaders(files, **values)
    team.run(0.1, 8.0, until=lambda t: all(t.state(r) in (AgentState.COMMITTED, AgentState.FAILED)
                                           for r in ('robot_a', 'robot_b')))
    states = {leader: team.report(leader).state for leader in ('robot_a', 'robot_b')}
    assert sorted(states.values()) == [AgentState.COMMITTED, AgentState.FAILED]
    failed = next(leader for leader, state in states.items() if state is AgentState.FAILED)
    detail = team.report(failed).detail
    assert 'no executable coalition could be set up' in detail and refusal in detail
    assert any(level == 'warning' and 'declined coalition' in text and refusal in text
               for level, text in team.ports['robot_h'].logs)
    assert len(team.report('robot_h').commitments) == 1
    assert max(len(report.commitments) for _, report in team.ports['robot_h'].statuses) == 1
    # (the refused leader may have tried a coalition relayed by the other leader, which shares)
    assert commitment_check(bag_of(team))['conflicting'] == {}


def test_a_driving_leader_keeps_its_task_and_declines_to_help_with_the_reason(files):
    """robot_3 needs robot_2 (which drives its own navigation): robot_2 says no, keeps its task
    and forms its own coalition; robot_3 fails and says why (before: robot_2 accepted, dropped its
    task and ended idle)."""
    team = column_team(files, 3, drive=True, max_reforms=0)
    team.run(0.1, 8.0, until=leaders_settled)
    assert team.report('robot_2').state is AgentState.COMMITTED
    assert team.report('robot_2').coalition_id and team.report('robot_2').leader == 'robot_2'
    assert AgentState.IDLE not in [r.state for _, r in team.ports['robot_2'].statuses[1:]]
    assert not any(c.leader == 'robot_3' for c in team.report('robot_2').commitments)
    report = team.report('robot_3')
    assert report.state is AgentState.FAILED and 'refused' in report.detail
    assert 'runs one motor schema at a time' in report.detail

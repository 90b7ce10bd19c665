"""Fuzzing the view nodes (issue 16): the visualiser and the live view, started by a session as
``--live`` starts them. The visualiser's inputs get: process roles with mismatched 100,000-state,
empty, NaN and zero-dt arrays, an unknown robot and a 10,000-character name, round 2^32-1, and a
flood of 300; assignments with mismatched arrays and NaN/1e308 goals; a map 100,000 x 100,000 cells
with no data and one with a NaN resolution; a team with an infinite radius; statuses without a
robot, with an unknown state and 100,000 members, and help lines between robots 1e308 m out; NaN,
infinite and 1e308 ground-truth poses; guidance and reports with invalid stamps; a bad /clock.
Both nodes stay up, log each kind of rejection once, everything kept can still be drawn, and
well-formed messages produce their markers, stamped on the simulation's clock. The live view's
WebSocket server gets a subscription to a channel that does not exist, a double unsubscribe,
garbage text and binary frames and a flood of 200; the SDK's reports go through the node's input
guard (once per kind, then counted), and a good client still receives the forwarded markers.
"""

import json
import math

import pytest
from builtin_interfaces.msg import Time
from bridge_interfaces.msg import BodyState, BodyStates
from coalition_interfaces.msg import AgentStatus, CoalitionCommitment
from nav_msgs.msg import OccupancyGrid
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from rosgraph_msgs.msg import Clock
from role_interfaces.msg import ProcessRole, RoleAssignment, Team, TeamMember
from sgcm_interfaces.msg import FollowerReport, Guidance
from visualization_msgs.msg import MarkerArray
from websockets.exceptions import ConnectionClosed

from foxglove_client import FoxgloveClient
from fuzz_helpers import BAD_STAMPS, LATCHED, assert_rejected_once_per_kind, bad_clock, clock_rejections_ok, \
    flood, publish_all, rejections

MARKERS = 'visualization_msgs/msg/MarkerArray'
ROBOT, OTHER = 'robot_view', 'robot_other'
LONG = 'r' * 10_000
SIM_SEC = 100
BEST_EFFORT = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)
#: Between messages on a latched topic: the visualiser keeps one (depth 1), so each is taken in turn.
LATCHED_PAUSE = 0.2
GARBAGE_FLOOD = 200


@pytest.fixture
def session(live_session):
    return live_session


def process_role(robot=ROBOT, round_=1, x=(0.0, 1.0), y=(0.0, 1.0), dt=0.5, start_time=0.0, **fields):
    return ProcessRole(robot=robot, role_id='diamond_0', round=round_, version=1, start_time=start_time, dt=dt,
                       radius=0.2, x=list(x), y=list(y), vx=[0.0] * len(x), vy=[0.0] * len(y), **fields)


def assignment(robots=(ROBOT,), goal_x=(1.0,), goal_y=(2.0,), round_=1, role_ids=None):
    return RoleAssignment(round=round_, status='assigned', robots=list(robots),
                          role_ids=list(role_ids if role_ids is not None else ['diamond_0'] * len(robots)),
                          goal_x=list(goal_x), goal_y=list(goal_y))


def bodies(**positions):
    msg = BodyStates()
    for name, (x, y) in positions.items():
        body = BodyState(name=name)
        body.pose.position.x, body.pose.position.y = x, y
        msg.bodies.append(body)
    return msg


def markers_with(session, topic, ns, text_prefix, timeout=15.0, also=()):
    """The first MarkerArray with a ``ns`` marker whose text starts with ``text_prefix`` and a marker
    of every namespace in ``also`` (the inputs arrive one by one: an array may hold some only)."""
    def found(array):
        return any(m.ns == ns and m.text.startswith(text_prefix) for m in array.markers) and \
            all(any(m.ns == other for m in array.markers) for other in also)
    return session.wait_for_message(topic, MARKERS, latched=True, timeout=timeout, predicate=found)


def test_view_nodes_survive_fuzzing_and_still_draw_and_forward(session, port):
    ros_node = session.observer.node
    assert set(session.nodes) == {'live_view', 'visualiser'}
    # The simulation's clock at 100 s (as a bridge publishes it): the bad /clock must not move it.
    publish_all(ros_node, Clock, '/clock', [Clock(clock=Time(sec=SIM_SEC))] * 3, qos=BEST_EFFORT, subscribers=2,
                pause=0.1)

    # Role engine inputs.
    bad_roles = [process_role(x=[0.0] * 100_000, y=[0.0]), process_role(x=[], y=[]),
                 process_role(dt=math.nan), process_role(dt=0.0), process_role(x=[math.nan, 1.0]),
                 process_role(robot='robot_ghost', round_=2 ** 32 - 1, x=[math.inf, 0.0]),
                 process_role(robot=LONG, start_time=1e308, dt=1e-308)]
    for stamp in BAD_STAMPS:
        role = process_role(robot='robot_stamped')
        role.header.stamp = stamp
        bad_roles.append(role)
    channel = publish_all(ros_node, ProcessRole, '/roles/channel', bad_roles)
    flood(channel, bad_roles[0], 300)
    publish_all(ros_node, RoleAssignment, '/roles/assignment', [
        assignment(robots=[ROBOT] * 100_000), assignment(goal_x=[math.nan]), assignment(goal_y=[1e308 * 10]),
        assignment(robots=[LONG], round_=2 ** 32 - 1, role_ids=['x' * 10_000])], qos=LATCHED, pause=LATCHED_PAUSE)
    huge_map, nan_map = OccupancyGrid(), OccupancyGrid()
    huge_map.info.width = huge_map.info.height = 100_000
    huge_map.info.resolution = 0.05
    nan_map.info.width = nan_map.info.height = 2
    nan_map.info.resolution = math.nan
    nan_map.data = [0] * 4
    publish_all(ros_node, OccupancyGrid, '/roles/map', [huge_map, nan_map], qos=LATCHED, pause=LATCHED_PAUSE)
    publish_all(ros_node, Team, '/roles/team', [Team(members=[TeamMember(name=ROBOT, robot_type='burger',
                                                                         radius=math.inf, color=[math.nan] * 3)])],
                qos=LATCHED, pause=LATCHED_PAUSE)

    # Coalition inputs (the status topics are found by the visualiser's discovery, once a second).
    helps = CoalitionCommitment(coalition_id=f'{ROBOT}/1', leader=ROBOT, members=[ROBOT, OTHER], cost=math.nan,
                                uses=['information:' + LONG])
    statuses = [AgentStatus(robot=''), AgentStatus(robot=OTHER, state=99, members=[OTHER] * 100_000),
                AgentStatus(robot=LONG, state=AgentStatus.FAILED, detail=LONG, cost=math.inf),
                AgentStatus(robot=OTHER, state=AgentStatus.COMMITTED, coalition_id=f'{ROBOT}/1',
                            commitments=[helps] * 3)]
    publish_all(ros_node, AgentStatus, f'/{OTHER}/coalition', statuses, qos=LATCHED, pause=LATCHED_PAUSE)
    publish_all(ros_node, BodyStates, '/ground_truth/bodies', [
        bodies(**{OTHER: (1e308, -1e308), ROBOT: (1e308, 1e308), LONG: (math.inf, math.nan)})], qos=LATCHED,
        pause=LATCHED_PAUSE)

    # SGCM inputs (no task file: kept, not drawn) with invalid stamps.
    guidance, reports = [], []
    for stamp in BAD_STAMPS:
        g, r = Guidance(), FollowerReport()
        g.header.stamp = r.header.stamp = stamp
        g.round = r.round = 2 ** 32 - 1
        guidance.append(g)
        reports.append(r)
    publish_all(ros_node, Guidance, '/sgcm/guidance', guidance)
    publish_all(ros_node, FollowerReport, '/sgcm/follower_report', reports)
    bad_clock(ros_node, subscribers=2)

    # Well-formed input still draws (in the colour of the team's robot, stamped on the simulation's clock).
    publish_all(ros_node, Team, '/roles/team', [Team(members=[TeamMember(name=ROBOT, robot_type='burger', radius=0.1,
                                                                         color=[1.0, 0.0, 0.0])])], qos=LATCHED)
    publish_all(ros_node, RoleAssignment, '/roles/assignment', [assignment()], qos=LATCHED, pause=LATCHED_PAUSE)
    publish_all(ros_node, ProcessRole, '/roles/channel', [process_role()])
    roles = markers_with(session, '/markers/roles', 'roles', f'{ROBOT}: diamond_0', also=('goals', 'now'))
    goal = next(m for m in roles.markers if m.ns == 'goals')
    assert (goal.pose.position.x, goal.pose.position.y) == (1.0, 2.0)
    assert (goal.color.r, goal.color.g, goal.color.b) == (1.0, 0.0, 0.0)
    assert goal.header.stamp.sec == SIM_SEC and goal.header.frame_id == 'world'
    assert any(m.ns == 'now' for m in roles.markers)
    publish_all(ros_node, BodyStates, '/ground_truth/bodies', [bodies(**{ROBOT: (1.0, 2.0)})], qos=LATCHED)
    publish_all(ros_node, AgentStatus, f'/{ROBOT}/coalition', [AgentStatus(robot=ROBOT, state=AgentStatus.COMMITTED)],
                qos=LATCHED, pause=LATCHED_PAUSE)
    coalitions = markers_with(session, '/markers/coalitions', 'states', f'{ROBOT}: COMMITTED', timeout=20.0)
    state = next(m for m in coalitions.markers if m.ns == 'states' and m.text.startswith(ROBOT))
    assert (state.pose.position.x, state.pose.position.y) == (1.0, 2.0)

    # The live view: a hostile client, then a good one.
    with FoxgloveClient(f'ws://127.0.0.1:{port}', timeout=20.0) as hostile:
        assert hostile.pump_until(lambda: '/markers/roles' in hostile.channels, 20.0), sorted(hostile.channels)
        try:
            hostile.ws.send(json.dumps({'op': 'subscribe', 'subscriptions': [{'id': 7, 'channelId': 999_999}]}))
            subscription = hostile.subscribe('/markers/roles')
            for _ in range(2):
                hostile.ws.send(json.dumps({'op': 'unsubscribe', 'subscriptionIds': [subscription]}))
            for frame in ('not json', '{"op": "bogus"}', '{"op": "subscribe", "subscriptions": "x"}', '[]',
                          b'\xff\x00garbage', b'', b'\x01' + b'\x00' * 3):
                hostile.ws.send(frame)
            for _ in range(GARBAGE_FLOOD):
                hostile.ws.send('not json')
            hostile.pump_until(lambda: False, 1.0)
        except ConnectionClosed:  # the server may close a client that speaks garbage; it must go on serving
            pass
    with FoxgloveClient(f'ws://127.0.0.1:{port}', timeout=20.0) as client:
        assert client.pump_until(lambda: '/markers/roles' in client.channels, 20.0), sorted(client.channels)
        client.subscribe('/markers/roles')

        def goal_forwarded() -> bool:
            return any(m.ns == 'goals' and m.pose.position.x == 1.0 for p in client.payloads('/markers/roles')
                       for m in deserialize_message(p, MarkerArray).markers)
        assert client.pump_until(goal_forwarded, 20.0), 'the good client received no roles markers'

    for name in ('visualiser', 'live_view'):
        assert session.nodes[name].poll() is None, f'{name} exited: {session.nodes[name].log_tail()}'
    visualiser = session.nodes['visualiser'].log_path.read_text()
    assert_rejected_once_per_kind(visualiser, '/roles/channel', [
        f'ValueError: process role of {ROBOT}', f'ValueError: process role of {ROBOT}.dt',
        f'ValueError: process role of {ROBOT}.x/y', 'ValueError: process role of robot_ghost.x/y'], at_least=False)
    assert_rejected_once_per_kind(visualiser, '/roles/assignment', [
        'ValueError: roles/assignment', 'ValueError: roles/assignment.goal_x/goal_y'], at_least=False)
    assert_rejected_once_per_kind(visualiser, '/roles/map', [
        'RoleEngineError: roles/map.data', 'RoleEngineError: roles/map.info.resolution'], at_least=False)
    assert_rejected_once_per_kind(visualiser, '/roles/team', ["RoleEngineError: robot_type 'burger'.radius"],
                                  at_least=False)
    assert_rejected_once_per_kind(visualiser, f'/{OTHER}/coalition', [f'ValueError: /{OTHER}/coalition.robot'],
                                  at_least=False)
    assert '/roles/channel: 100 malformed messages dropped so far' in visualiser  # the flood: counted
    # What was kept could always be drawn: no picture was dropped after its input was accepted.
    for source in ('sgcm', 'roles', 'coalitions'):
        assert not rejections(visualiser, f'markers/{source}'), rejections(visualiser, f'markers/{source}')
    clock_rejections_ok(visualiser)
    clock_rejections_ok(session.nodes['live_view'].log_path.read_text())
    assert 'Traceback' not in visualiser
    # The SDK's reports of the hostile client, once per kind through the node's input guard, then counted.
    live_view = session.nodes['live_view'].log_path.read_text()
    assert_rejected_once_per_kind(live_view, 'websocket', [
        'ValueError: Client #:# attempted to subscribe to unknown channel', 'ValueError: Invalid message from #:#'],
        at_least=False)
    assert 'websocket: 100 malformed messages dropped so far' in live_view
    assert 'Traceback' not in live_view

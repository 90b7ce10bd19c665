"""Fuzzing the role engine, the robot tracker and the role players (issue 16 items 1-2).

Four robots start 0.4 m outside their diamond (a short formation, so the test stays short). Once
the players play their roles, every role node gets: process roles of an unknown robot, with empty,
mismatched, 100,000-state, NaN, huge-dt and infinite-radius arrays, and a flood of them; an
assignment whose initial role is malformed (it ended all four players with exit code 2) and one
with a negative stamp; a team description with no robot; NaN tracked poses; camera images and a
map with invalid stamps; a bad /clock. Sessions and senders (issue 16 item 4, core.sessions):
assignments of another sender, without a session, and with round 2^32-1 (in the engine's session
and as a new one's first round); process roles sent by another robot's node (one claiming an
arrival) or of another session; player announcements of a robot from a node not its own and of a
robot not in the team. Every node stays up, logs each kind of rejection once, and the formation
still completes (the forged round did not silence the players, the forged arrival did not end it).
"""

import math
import time
from builtin_interfaces.msg import Time
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import OccupancyGrid
from rclpy.qos import qos_profile_sensor_data
from role_interfaces.msg import PlayerAnnouncement, ProcessRole, RoleAssignment, Team
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Image

from collab_tools.orchestration.node_process import NodeSpec
from fuzz_helpers import BAD_STAMPS, HUGE, LATCHED, NEGATIVE, assert_rejected_once_per_kind, bad_clock, \
    clock_rejections_ok, flood, publish_all, rejections, \
    republish_until_rejected
from role_engine.core.formation_task import load_formation_task
from role_helpers import engine_spec, player_process, player_spec, short_formation, tracker_spec
from test_role_nodes import ROBOTS, assert_formation_completed, watch_ground_truth_and_arrivals

def role(robot, round_, stamp=None, session=0, sender=None, **fields):
    """A process role of ``robot`` sent by its player (``sender`` None) in ``session``."""
    values = {'sender': sender if sender is not None else f'/{robot}/role_player', 'session': session,
              'robot': robot, 'role_id': 'diamond_0', 'round': round_, 'version': 7, 'start_time': 1.0, 'dt': 0.5,
              'radius': 0.2, 'x': [0.0, 0.1, 0.2], 'y': [0.0, 0.0, 0.0], 'vx': [0.2] * 3, 'vy': [0.0] * 3}
    values.update(fields)
    msg = ProcessRole(**values)
    if stamp is not None:
        msg.header.stamp = stamp
    return msg


def malformed_roles(round_, session):
    """Process roles of the current session and round, from their robot's node, that cannot be converted."""
    many = [0.0] * 100_000
    return [
        role('ghost_robot', round_, session=session),                                        # unknown id
        role('pioneer_1', round_, session=session, x=[], y=[], vx=[], vy=[]),                # empty arrays
        role('pioneer_1', round_, session=session, x=[0.0, 1.0, 2.0], y=[0.0]),             # mismatched
        role('pioneer_1', round_, session=session, x=many, y=many, vx=many, vy=many),        # huge arrays
        role('pioneer_1', round_, session=session, x=[math.nan, 0.0, 0.0]),                  # NaN
        role('pioneer_1', round_, session=session, dt=1e300),                                # a role of 1e300 s
        role('pioneer_1', round_, session=session, radius=math.inf),
        role('pioneer_1', round_, session=session, x=[1e308, 0.0, 0.0]),                     # finite, absurd
    ]


def out_of_session_roles(current):
    """Well-formed process roles the engine and the players must ignore: another robot's node claims
    burger_1 has arrived, a role of another session, and round 2^32-1 (ignored as not the round)."""
    round_, session = current.round, current.session
    return [
        role('burger_1', round_, session=session, sender='/pioneer_2/role_player', arrived=True),  # forged sender
        role('pioneer_2', round_, session=session ^ 1),                                          # other session
        role('pioneer_2', 2**32 - 1, session=session),                                           # absurd round
    ]


def player_channel_kinds(robot):
    """What a player rejects on the channel; it ignores roles naming its own robot (burger_1's forged
    arrival, pioneer_2's other session)."""
    return (['unknown robot'] + (['forged sender'] if robot != 'burger_1' else [])
            + (['other session'] if robot != 'pioneer_2' else []))


def out_of_session_assignments(current):
    """Assignments a player must refuse: another sender, round 2^32-1 in the engine's session and as a new
    session's first round, no session. Each would stop the players if it were applied (status aborted)."""
    def aborted(sender, session, round_):
        msg = RoleAssignment(sender=sender, session=session, round=round_, status='aborted', message='forged')
        msg.header.stamp = Time(sec=current.header.stamp.sec, nanosec=current.header.stamp.nanosec)
        return msg
    return [aborted('/evil/role_engine', current.session, current.round + 1),
            aborted(current.sender, current.session, 2**32 - 1),
            aborted(current.sender, current.session ^ 1, 2**32 - 1),
            aborted(current.sender, 0, current.round + 1)]


def forged_announcements():
    """pioneer_1's announcement from a node not its own, one of a robot not in the team, and a genuine one
    of a robot in the round (nothing to do)."""
    return [PlayerAnnouncement(sender='/evil/role_player', robot='pioneer_1'),
            PlayerAnnouncement(sender='/ghost_robot/role_player', robot='ghost_robot'),
            PlayerAnnouncement(sender='/pioneer_1/role_player', robot='pioneer_1')]


def bad_assignments(current):
    """An assignment of the next round whose initial role cannot be played, and one with a negative stamp."""
    stamp = Time(sec=current.header.stamp.sec, nanosec=current.header.stamp.nanosec)
    broken = RoleAssignment(sender=current.sender, session=current.session, round=current.round + 1,
                            status='assigned', message='fuzz', robots=list(ROBOTS),
                            role_ids=[f'diamond_{i}' for i in range(4)], goal_x=[0.0] * 4, goal_y=[0.0] * 4,
                            initial_roles=[role(robot, current.round + 1, session=current.session,
                                                sender=current.sender, dt=1e6) for robot in ROBOTS])
    broken.header.stamp = stamp
    negative = RoleAssignment(sender=current.sender, session=current.session, round=current.round + 1,
                              status='assigned')
    negative.header.stamp = NEGATIVE
    return [broken, negative]


def test_role_nodes_survive_fuzzing_and_complete_the_formation(session, ros_node, tmp_path):
    began = time.monotonic()
    settings = short_formation(tmp_path)
    session.start(NodeSpec('pybullet_bridge', 'pybullet_bridge', name='pybullet_bridge', use_sim_time=False,
                           parameters=[{'scenario': str(tmp_path / 'scenario.yaml'), 'real_time_factor': 0.5,
                                        'ground_truth_rate': 20.0}]))
    engine = session.start(engine_spec(settings))
    tracker = session.start(tracker_spec())
    for robot in ROBOTS:
        session.start(player_spec(robot, settings, required=True))
    task_truth, arrived = watch_ground_truth_and_arrivals(session, load_formation_task(settings))
    assignment = session.wait_for_message('/roles/assignment', 'role_interfaces/msg/RoleAssignment',
                                          timeout=90, latched=True)
    assert assignment.status == 'assigned', assignment.message
    session.wait_for_message('/roles/channel', 'role_interfaces/msg/ProcessRole',
                             predicate=lambda m: m.version >= 1, timeout=60)
    round_ = assignment.round

    # The channel: engine + four players hear it.
    # (a player busy re-planning keeps the newest 10 messages: spaced, each kind reaches every node)
    epoch = assignment.session
    fuzz_roles = malformed_roles(round_, epoch) + out_of_session_roles(assignment)
    channel = publish_all(ros_node, ProcessRole, '/roles/channel', fuzz_roles, subscribers=5, pause=0.2)
    republish_until_rejected(channel, fuzz_roles, '/roles/channel', {
        engine.log_path: ['unknown robot', 'forged sender', 'other session'],
        **{player_process(session, robot).log_path: player_channel_kinds(robot) for robot in ROBOTS}})
    time.sleep(1.0)
    flood(channel, role('pioneer_1', round_, session=epoch, x=[math.nan] * 3), 200, seconds=1.0)
    # The assignment (players only) and the team (players and tracker; the tracker converts it).
    # (the players keep one assignment: a pause lets each be taken before the next)
    publish_all(ros_node, RoleAssignment, '/roles/assignment',
                bad_assignments(assignment) + out_of_session_assignments(assignment), qos=LATCHED,
                subscribers=4, pause=0.5)
    publish_all(ros_node, PlayerAnnouncement, '/roles/players', forged_announcements(), subscribers=1, pause=0.2)
    publish_all(ros_node, Team, '/roles/team', [Team()], qos=LATCHED, subscribers=5)
    # A player's tracked pose, the camera, the map.
    nan_pose = PoseStamped()
    nan_pose.pose.position.x = math.nan
    publish_all(ros_node, PoseStamped, '/pioneer_1/tracked_pose', [nan_pose] * 3, qos=qos_profile_sensor_data)
    images = []
    for stamp in BAD_STAMPS:
        image = Image(encoding='rgb8', height=0, width=0, step=0)
        image.header.stamp = stamp
        images.append(image)
    publish_all(ros_node, Image, '/top_camera/image_raw', images, qos=qos_profile_sensor_data, subscribers=2)
    bad_map = OccupancyGrid()
    bad_map.header.stamp = NEGATIVE
    publish_all(ros_node, OccupancyGrid, '/roles/map', [bad_map], qos=LATCHED, subscribers=4)
    clock = bad_clock(ros_node, subscribers=6)
    flood(clock, Clock(clock=HUGE), 30, seconds=0.3)
    session.check_alive()

    assert_formation_completed(task_truth, arrived, assignment, timeout=60.0)
    session.check_alive()
    engine_log = engine.log_path.read_text()
    assert_rejected_once_per_kind(engine_log, '/roles/channel', ['unknown robot', 'forged sender', 'other session'])
    assert_rejected_once_per_kind(engine_log, '/roles/players', ['forged sender', 'unknown robot'])
    assert 'is back' not in engine_log                      # the genuine announcement of a playing robot: nothing
    assert len(rejections(engine_log, '/roles/channel')) >= 5
    assert '/roles/channel: 100 malformed messages dropped so far' in engine_log
    assert_rejected_once_per_kind(engine_log, '/top_camera/image_raw', ['header.stamp: negative',
                                                                         'header.stamp: far ahead'])
    clock_rejections_ok(engine_log)
    tracker_log = tracker.log_path.read_text()
    assert_rejected_once_per_kind(tracker_log, '/roles/team', ['team description'])
    clock_rejections_ok(tracker_log)
    for robot in ROBOTS:
        log = player_process(session, robot).log_path.read_text()
        assert_rejected_once_per_kind(log, '/roles/channel', player_channel_kinds(robot))
        kinds = rejections(log, '/roles/assignment')
        assert 'header.stamp: negative' in kinds and any(k.startswith('assignment: ') for k in kinds), kinds
        assert_rejected_once_per_kind(log, '/roles/assignment', ['other sender', 'round jump', 'no session'])
        assert_rejected_once_per_kind(log, '/roles/map', ['header.stamp: negative'])
        clock_rejections_ok(log)
        assert 'no role' not in log, robot               # the broken assignment never reached the player
    pioneer = player_process(session, 'pioneer_1').log_path.read_text()
    assert rejections(pioneer, '/pioneer_1/tracked_pose'), 'the NaN pose was dropped and logged'
    print(f'role nodes fuzz: {time.monotonic() - began:.0f} s (wall)')

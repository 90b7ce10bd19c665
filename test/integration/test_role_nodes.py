"""role_engine, the robot_tracker and four role_players form the diamond on the bridge through topics only.

The engine runs as /role_engine, each player in its robot's namespace (/<robot>/role_player), so
the four players have four unique node names.

The nodes see the robots only through the top-view camera (colour tracking: the engine's own and
the robot_tracker's, whose per-robot poses the players follow). The players read no scenario: in
the diamond test their settings file names a scenario that does not exist (as on a robot with no
bridge files), and the team and the round's map reach them from the engine's topics. The test
checks against the bridge's ground truth: every robot ends at its assigned formation
point, and no two robot discs ever overlap. A stopped role player makes the engine
renegotiate and the other three still complete a formation (on the short formation of
role_helpers: the full demo drive is the diamond test's); a malformed process role on
the channel is dropped with a log line; a bad parameter stops each node with exit code 2 and a
message naming it.
"""

import itertools
import math
import threading
import time

import pytest
from bridge_interfaces.msg import BodyStates
from role_interfaces.msg import ProcessRole, RoleAssignment

from collab_tools.qos import RELIABLE
from bridge_helpers import bridge_spec
from role_helpers import QUICK_START, engine_spec, player_node, player_process, player_spec, \
    settings_without_scenario, short_formation, tracker_spec
from pybullet_bridge.core.scenario import load_scenario
from role_engine.core.formation_task import load_formation_task

#: Simulated seconds per wall second the two shared cores sustain with the bridge and five nodes.
REAL_TIME_FACTOR = 0.5
ROBOTS = ('pioneer_1', 'pioneer_2', 'burger_1', 'burger_2')
#: Tolerance on the final ground-truth position [m]: arrival tolerance plus camera tracking error.
GOAL_TOLERANCE = 0.15


@pytest.fixture
def settings_file(config_dir):
    return config_dir / 'roles' / 'formation_demo.yaml'


class GroundTruthLog:
    """Keeps the newest ground truth and the smallest gap between two robots' discs."""

    def __init__(self, node, radii):
        self.radii = radii
        self.lock = threading.Lock()
        self.latest = {}
        self.min_gap = math.inf
        self.closest = None
        self.samples = 0
        node.create_subscription(BodyStates, '/ground_truth/bodies', self._on_bodies, 10)

    def _on_bodies(self, msg):
        positions = {b.name: (b.pose.position.x, b.pose.position.y) for b in msg.bodies if b.name in self.radii}
        with self.lock:
            self.latest = positions
            self.samples += 1
            for a, b in itertools.combinations(sorted(positions), 2):
                gap = math.dist(positions[a], positions[b]) - self.radii[a] - self.radii[b]
                if gap < self.min_gap:
                    self.min_gap, self.closest = gap, (a, b)


def start_nodes(session, settings_file, robots=ROBOTS, player_settings=None, **engine_parameters):
    """The bridge, the engine (with ``engine_parameters``), the tracker and the players (with
    ``player_settings`` when given)."""
    task = load_formation_task(settings_file)
    session.start(bridge_spec(task.scenario, real_time_factor=REAL_TIME_FACTOR, start_paused=False,
                              ground_truth_rate=20.0))
    session.start(engine_spec(settings_file, **engine_parameters))
    session.start(tracker_spec())
    for robot in robots:
        session.start(player_spec(robot, player_settings or settings_file))
    return task


def watch_ground_truth_and_arrivals(session, task):
    scenario = load_scenario(task.scenario)
    radii = {r.name: r.params.radius for r in scenario.sections['mobile_robots']}
    truth = GroundTruthLog(session.observer.node, radii)
    arrived = set()                                     # (round, robot)
    session.observer.node.create_subscription(
        ProcessRole, '/roles/channel', lambda m: m.arrived and arrived.add((m.round, m.robot)), 50)
    return truth, arrived


def assert_formation_completed(truth, arrived, assignment, timeout):
    """Every robot of ``assignment`` reports arrival; ground truth: at its point, never touching another."""
    expected = {(assignment.round, robot) for robot in assignment.robots}
    began = time.monotonic()
    while not expected <= arrived and time.monotonic() < began + timeout:
        time.sleep(0.5)
    wall = time.monotonic() - began
    assert expected <= arrived, f'only {sorted(arrived & expected)} arrived within {wall:.0f} s'
    time.sleep(1.0)
    with truth.lock:
        final, min_gap, closest, samples = dict(truth.latest), truth.min_gap, truth.closest, truth.samples
    print(f'round {assignment.round}: formation formed {wall:.1f} s (wall) after the assignment; min gap '
          f'between robot discs {min_gap:.3f} m ({closest}), {samples} ground-truth samples')
    assert samples > 100
    for robot, x, y in zip(assignment.robots, assignment.goal_x, assignment.goal_y):
        error = math.dist(final[robot], (x, y))
        assert error <= GOAL_TOLERANCE, f'{robot} ended {error:.3f} m from its formation point ({x:.2f}, {y:.2f})'
    assert min_gap > 0.0, f'{closest} collided (gap {min_gap:.3f} m)'


def test_role_players_form_the_diamond_without_collision(session, settings_file, tmp_path):
    began = time.monotonic()
    # The players' settings name a scenario that does not exist: they need no file of the bridge's.
    player_settings = settings_without_scenario(settings_file, tmp_path)
    assert not load_formation_task(player_settings, check_scenario=False).scenario.exists()
    task = start_nodes(session, settings_file, player_settings=player_settings)
    truth, arrived = watch_ground_truth_and_arrivals(session, task)
    assignment = session.wait_for_message('/roles/assignment', 'role_interfaces/msg/RoleAssignment',
                                          timeout=60, latched=True)
    assert assignment.status == 'assigned', assignment.message
    assert sorted(assignment.robots) == sorted(ROBOTS)
    assert len(set(assignment.role_ids)) == 4
    # The round's map, latched for the players: Nav2's conventions over the arena, the assignment's stamp.
    grid = session.wait_for_message('/roles/map', 'nav_msgs/msg/OccupancyGrid', timeout=30, latched=True)
    assert grid.header.stamp == assignment.header.stamp and grid.header.frame_id == 'world'
    assert (grid.info.width, grid.info.height) == (100, 100) and grid.info.resolution == pytest.approx(0.05)
    assert (grid.info.origin.position.x, grid.info.origin.position.y) == (-2.5, -2.5)
    assert 0 < sum(1 for v in grid.data if v == 100) < 0.2 * len(grid.data)     # the pillar, crate and shelf
    # One node per robot, each named role_player in its robot's namespace: four unique names.
    session.wait_for_nodes(['/role_engine', '/robot_tracker'] + [player_node(robot) for robot in ROBOTS],
                           timeout=30.0)
    graph = session.observer.node.get_node_names_and_namespaces()
    players = sorted(ns for name, ns in graph if name == 'role_player')
    assert players == sorted(f'/{robot}' for robot in ROBOTS)
    assert ('role_engine', '/') in graph
    # A malformed process role of this round (x and y of different lengths) is dropped by the
    # engine and the other players with a log line; nobody crashes and the formation completes.
    publisher = session.observer.node.create_publisher(ProcessRole, '/roles/channel', RELIABLE)
    deadline = time.monotonic() + 20.0                  # the engine, four players and our own watcher
    while publisher.get_subscription_count() < len(ROBOTS) + 2 and time.monotonic() < deadline:
        time.sleep(0.1)
    assert publisher.get_subscription_count() >= len(ROBOTS) + 2
    # (sent as pioneer_1's player in the engine's session: other senders and sessions are ignored before
    # the conversion, core.sessions)
    publisher.publish(ProcessRole(sender='/pioneer_1/role_player', session=assignment.session, robot='pioneer_1',
                                  role_id='diamond_0', round=assignment.round, version=99,
                                  start_time=0.0, dt=0.5, radius=0.2, x=[0.0, 1.0, 2.0], y=[0.0], vx=[0.0],
                                  vy=[0.0]))
    assert_formation_completed(truth, arrived, assignment, timeout=100.0)
    for process in (session.nodes['role_engine'], player_process(session, 'burger_1')):
        log = process.log_path.read_text()
        assert "dropped malformed process role: process role of 'pioneer_1': x, y, vx, vy must have one " \
               'equal length' in log, process.name
    print(f'diamond test took {time.monotonic() - began:.0f} s (wall)')


def test_role_engine_renegotiates_when_a_role_player_stops(session, tmp_path):
    began = time.monotonic()
    # The short formation (robots 0.4 m outside the diamond, 6 s roles): burger_2 stops early in its role,
    # while the others still play theirs, and the three-robot round is short.
    task = start_nodes(session, short_formation(tmp_path), **QUICK_START)
    truth, arrived = watch_ground_truth_and_arrivals(session, task)
    first = session.wait_for_message('/roles/assignment', 'role_interfaces/msg/RoleAssignment',
                                     timeout=60, latched=True)
    assert first.status == 'assigned', first.message
    # Let the players start their roles, then silence one of them.
    session.wait_for_message('/roles/channel', 'role_interfaces/msg/ProcessRole',
                             predicate=lambda m: m.robot == 'burger_2' and m.version >= 2, timeout=60)
    session.stop(player_process(session, 'burger_2').name)
    second = session.wait_for_message('/roles/assignment', 'role_interfaces/msg/RoleAssignment',
                                      predicate=lambda m: m.round == first.round + 1, timeout=60)
    assert second.status == 'assigned', second.message
    assert 'burger_2' not in second.robots and sorted(second.robots) == ['burger_1', 'pioneer_1', 'pioneer_2']
    assert second.excluded_robots == ['burger_2']
    assert 'burger_2 went silent' in second.message
    # The remaining three complete a formation (the stopped robot is an obstacle for them).
    assert_formation_completed(truth, arrived, second, timeout=120.0)
    print(f'renegotiation test took {time.monotonic() - began:.0f} s (wall)')


# One start-up refusal per executable (every other bad value: test/unit/roles/test_role_settings.py): a
# tuning value of the engine, one of a player (declared once the engine's team names its robot's type),
# one of the tracker; each stops its node with exit code 2 and the message.
@pytest.mark.parametrize('executable, parameters, expected', [
    ('role_engine', {'min_robots': 0}, 'parameter min_robots: must be in [1, inf]'),
    ('role_player', {'max_linear_velocity': 0.5}, 'parameter max_linear_velocity: must be in (0, 0.22]'),
    ('robot_tracker', {'min_area_px': 0}, 'parameter min_area_px: must be in [1, inf]'),
])
def test_a_bad_parameter_stops_the_node_with_a_message(session, settings_file, executable, parameters, expected):
    if executable == 'role_engine':
        spec = engine_spec(settings_file, **parameters)
    elif executable == 'role_player':                         # burger's limit is 0.22 m/s; it comes with the team
        session.start(engine_spec(settings_file))
        spec = player_spec('burger_1', settings_file, **parameters)
    else:
        spec = tracker_spec(**parameters)
    process = session.start(spec)
    assert session.wait_for_exit(spec.label, timeout=60.0) == 2
    log = process.log_path.read_text()
    assert expected in log
    assert 'Traceback' not in log

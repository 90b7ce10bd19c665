"""role_engine and four role_players form the diamond on the bridge through topics only.

The nodes see the robots only through the top-view camera (colour tracking); the test
checks against the bridge's ground truth: every robot ends at its assigned formation
point, and no two robot discs ever overlap.
"""

import itertools
import math
import threading
import time

import pytest
from bridge_interfaces.msg import BodyStates
from role_interfaces.msg import ProcessRole, RoleAssignment

from collab_tools.orchestration.node_process import NodeSpec
from bridge_helpers import bridge_spec
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


def start_nodes(session, settings_file, robots=ROBOTS):
    task = load_formation_task(settings_file)
    session.start(bridge_spec(task.scenario, real_time_factor=REAL_TIME_FACTOR, start_paused=False,
                              ground_truth_rate=20.0))
    session.start(NodeSpec('role_engine', 'role_engine', name='role_engine',
                           parameters=[{'settings_file': str(settings_file)}]))
    for robot in robots:
        session.start(NodeSpec('role_engine', 'role_player', name=f'role_player_{robot}',
                               parameters=[{'settings_file': str(settings_file), 'robot': robot}],
                               required=False))
    return task


def test_role_players_form_the_diamond_without_collision(session, settings_file):
    task = start_nodes(session, settings_file)
    scenario = load_scenario(task.scenario)
    radii = {r.name: r.params.radius for r in scenario.sections['mobile_robots']}
    truth = GroundTruthLog(session.observer.node, radii)
    arrived = set()
    session.observer.node.create_subscription(
        ProcessRole, '/roles/channel', lambda m: m.arrived and arrived.add(m.robot), 50)
    assignment = session.wait_for_message('/roles/assignment', 'role_interfaces/msg/RoleAssignment',
                                          timeout=60, latched=True)
    assert assignment.status == 'assigned', assignment.message
    assert sorted(assignment.robots) == sorted(ROBOTS)
    assert len(set(assignment.role_ids)) == 4
    began = time.monotonic()
    deadline = began + 100.0
    while arrived != set(ROBOTS) and time.monotonic() < deadline:
        time.sleep(0.5)
    wall = time.monotonic() - began
    assert arrived == set(ROBOTS), f'only {sorted(arrived)} arrived within {wall:.0f} s'
    time.sleep(1.0)
    with truth.lock:
        final, min_gap, closest, samples = dict(truth.latest), truth.min_gap, truth.closest, truth.samples
    print(f'formation formed {wall:.1f} s (wall) after the assignment; min gap between robot discs '
          f'{min_gap:.3f} m ({closest}), {samples} ground-truth samples')
    assert samples > 100
    for robot, x, y in zip(assignment.robots, assignment.goal_x, assignment.goal_y):
        error = math.dist(final[robot], (x, y))
        assert error <= GOAL_TOLERANCE, f'{robot} ended {error:.3f} m from its formation point ({x:.2f}, {y:.2f})'
    assert min_gap > 0.0, f'{closest} collided (gap {min_gap:.3f} m)'


def test_role_engine_renegotiates_when_a_role_player_stops(session, settings_file):
    start_nodes(session, settings_file)
    first = session.wait_for_message('/roles/assignment', 'role_interfaces/msg/RoleAssignment',
                                     timeout=60, latched=True)
    assert first.status == 'assigned', first.message
    # Let the players start their roles, then silence one of them.
    session.wait_for_message('/roles/channel', 'role_interfaces/msg/ProcessRole',
                             predicate=lambda m: m.robot == 'burger_2' and m.version >= 2, timeout=60)
    session.stop('role_player_burger_2')
    second = session.wait_for_message('/roles/assignment', 'role_interfaces/msg/RoleAssignment',
                                      predicate=lambda m: m.round == first.round + 1, timeout=60)
    assert second.status == 'assigned', second.message
    assert 'burger_2' not in second.robots and sorted(second.robots) == ['burger_1', 'pioneer_1', 'pioneer_2']
    assert second.excluded_robots == ['burger_2']
    assert 'burger_2 went silent' in second.message

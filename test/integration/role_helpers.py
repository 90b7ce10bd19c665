"""Starting the role nodes in a test session: the engine in the team namespace, each player in its robot's.

Also the short formation the fuzz, restart and renegotiation tests play (the demo's full drive is the
diamond test's in test_role_nodes.py) and a log of every assignment for tests that watch several engines.
"""

import math
import threading
import time
from pathlib import Path

import yaml
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from role_interfaces.msg import RoleAssignment

from collab_tools.orchestration.node_process import NodeSpec

CONFIG = Path(__file__).resolve().parents[2] / 'config'
ENGINE = '/role_engine'
TRACKER = '/robot_tracker'


def player_node(robot: str) -> str:
    """Full ROS name of a robot's role player."""
    return f'/{robot}/role_player'


def engine_spec(settings_file, **parameters) -> NodeSpec:
    return NodeSpec('role_engine', 'role_engine', name='role_engine',
                    parameters=[{'settings_file': str(settings_file), **parameters}])


def tracker_spec(**parameters) -> NodeSpec:
    """``/robot_tracker``: the robots' poses from the top camera for the players."""
    return NodeSpec('role_engine', 'robot_tracker', name='robot_tracker',
                    parameters=[dict(parameters)] if parameters else [])


def player_spec(robot: str, settings_file, required: bool = False, **parameters) -> NodeSpec:
    """``/<robot>/role_player`` (no robot parameter: the namespace says it); session label ``<robot>/role_player``."""
    return NodeSpec('role_engine', 'role_player', namespace=f'/{robot}', required=required,
                    parameters=[{'settings_file': str(settings_file), **parameters}])


def settings_without_scenario(settings_file, directory):
    """A copy of the settings file whose scenario does not exist, as on a robot with no bridge files."""
    data = yaml.safe_load(Path(settings_file).read_text())
    data['scenario'] = '/nonexistent/host/scenario.yaml'
    path = Path(directory) / 'player_settings.yaml'
    path.write_text(yaml.safe_dump(data))
    return path


def player_process(session, robot: str):
    """The session's process of ``robot``'s role player."""
    for process in session.nodes.values():
        if process.spec.executable == 'role_player' and (process.spec.namespace or '').split('/')[-1] == robot:
            return process
    raise AssertionError(f'no role player of {robot} in the session ({", ".join(session.nodes)})')


#: The vertex of the demo's diamond (size 2.2: (+-1.1, 0), (0, +-1.1)) each robot of the short formation starts
#: outside of, and its heading there (facing the centre).
SHORT_VERTICES = {'pioneer_1': (-1.1, 0.0, 0.0), 'pioneer_2': (1.1, 0.0, math.pi),
                  'burger_1': (0.0, -1.1, math.pi / 2), 'burger_2': (0.0, 1.1, -math.pi / 2)}


#: Engine parameters of the short-formation tests: roles start 1 s (ROS time) after their assignment, not the
#: demo's 2 s (a player takes its initial role from the assignment: nothing to plan before it starts).
QUICK_START = {'start_delay': 1.0}


def short_formation(directory: Path, outside: float = 0.4, total_time: float = 6.0) -> Path:
    """formation_demo with each robot ``outside`` m beyond its diamond vertex (facing in), only the pillar,
    and roles of ``total_time`` s (0.5 s per support state); writes scenario.yaml and settings.yaml into
    ``directory`` and returns the settings."""
    scenario = yaml.safe_load((CONFIG / 'scenarios' / 'roles_formation.yaml').read_text())
    for robot in scenario['mobile_robots']:
        x, y, yaw = SHORT_VERTICES[robot['name']]
        scale = (math.hypot(x, y) + outside) / math.hypot(x, y)
        robot['pose'] = [x * scale, y * scale, yaw]
    scenario['obstacles']['boxes'] = [b for b in scenario['obstacles']['boxes'] if b['name'] == 'pillar']
    (directory / 'scenario.yaml').write_text(yaml.safe_dump(scenario))
    settings = yaml.safe_load((CONFIG / 'roles' / 'formation_demo.yaml').read_text())
    settings['scenario'] = str(directory / 'scenario.yaml')
    settings['trajectory'] = {'total_time': total_time, 'states': round(total_time / 0.5) + 1}
    path = directory / 'settings.yaml'
    path.write_text(yaml.safe_dump(settings))
    return path


class AssignmentLog:
    """Every /roles/assignment the test's node hears (latched: also each engine's newest one before it
    subscribed), so several engines' rounds can be awaited in any order without missing one."""

    def __init__(self, node):
        self.lock = threading.Lock()
        self.heard = []
        # Deeper than LATCHED's one message: three engines may publish at once.
        qos = QoSProfile(depth=20, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        node.create_subscription(RoleAssignment, '/roles/assignment', self._on_assignment, qos)

    def _on_assignment(self, msg):
        with self.lock:
            self.heard.append(msg)

    def wait(self, predicate, timeout: float, what: str):
        """The first assignment heard for which ``predicate`` holds."""
        deadline = time.monotonic() + timeout
        while True:
            with self.lock:
                found = next((m for m in self.heard if predicate(m)), None)
                heard = [(m.sender, m.round, m.status) for m in self.heard]
            if found is not None:
                return found
            assert time.monotonic() < deadline, f'timed out after {timeout:.0f} s waiting for {what}; heard {heard}'
            time.sleep(0.2)

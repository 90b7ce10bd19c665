"""set_parameters on role_engine and a role player: every dynamic parameter is applied, every other one
is refused (read-only), and so is a value of the wrong type or out of range. Bad start-up values:
test/unit/roles/test_role_settings.py (and one exit-code test per node in test_role_nodes.py).

What each dynamic parameter changes is observed where it shows outside the node: the engine's
start delay in the assignment, its silence / stuck / off-role thresholds and min_robots in why it
aborts (no role player runs, so the robots fall silent or stay still); the player's re-plan period
in its channel heartbeat, its velocity caps on cmd_vel, its arrival tolerance in its ``arrived``
report. The GP, avoidance and controller-gain values reach the re-plan and the controller through
the same tuning object (unit tests: test_roles_tuning.py); here they are set and the player keeps
re-planning. Times are compared in simulated time (message stamps), so a slow machine cannot fail them.
"""

import re
import statistics
import threading
import time

import pytest
from geometry_msgs.msg import Twist
from role_interfaces.msg import ProcessRole

from collab_tools.qos import RELIABLE, SENSOR_IN
from bridge_helpers import bridge_spec
from parameter_client import check_parameter_contract, descriptors, get_values, set_one
from role_engine.core.formation_task import load_formation_task
from role_engine.core.node_settings import ENGINE_TUNING, PLAYER_TUNING
from role_helpers import ENGINE, AssignmentLog, engine_spec, player_node, player_process, player_spec, tracker_spec

ENGINE_READ_ONLY = {'settings_file', 'camera', 'exit_when_done', 'team_namespace'}
PLAYER_READ_ONLY = {'settings_file', 'engine', 'robot', 'team_namespace'}   # no camera: it follows tracked_pose
#: The engine never excludes a robot: the player test watches one player alone.
PATIENT_ENGINE = {'silence_timeout': 1000.0, 'problem_detection.stuck_time': 1000.0,
                  'problem_detection.off_role_distance': 100.0}


@pytest.fixture
def settings_file(config_dir):
    return config_dir / 'roles' / 'formation_demo.yaml'


def start_stamp(msg):
    return msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9


def wait_until(condition, timeout, what):
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, f'timed out after {timeout:.0f} s waiting for {what}'
        time.sleep(0.2)


# ------------------------------------------------------------------------------------ role_engine
def test_role_engine_applies_its_tuning_and_refuses_the_rest(session, settings_file):
    task = load_formation_task(settings_file)
    session.start(engine_spec(settings_file))
    session.wait_for_nodes([ENGINE], timeout=60.0)
    found = check_parameter_contract(session, ENGINE, ENGINE_TUNING, ENGINE_READ_ONLY)
    assert found['min_robots'].integer_range[0].from_value == 1
    assert found['silence_timeout'].floating_point_range[0].from_value == 0.0
    for name, value, reason in (('start_delay', 'soon', None), ('min_robots', 2.5, None),
                                ('min_robots', 0, 'min_robots'), ('silence_timeout', -1.0, 'silence_timeout')):
        result = set_one(session, ENGINE, name, value)
        assert not result.successful, (name, value)
        assert reason is None or reason in result.reason
    # Before the camera is up: the first negotiation uses these.
    changes = {'start_delay': 5.0, 'qualification_lambda': 0.5, 'min_robots': 2, 'silence_timeout': 6.0,
               'problem_detection.stuck_time': 200.0, 'problem_detection.off_role_distance': 50.0}
    for name, value in changes.items():
        result = set_one(session, ENGINE, name, value)
        assert result.successful, (name, result.reason)
    assert get_values(session, ENGINE, changes) == changes
    assignments = AssignmentLog(session.observer.node)
    session.start(bridge_spec(task.scenario, real_time_factor=1.0, start_paused=False))
    first = assignments.wait(lambda m: m.sender == ENGINE, 90, "the engine's first assignment")
    assert first.status == 'assigned', first.message
    start = first.initial_roles[0].start_time
    assert start - start_stamp(first) == pytest.approx(5.0, abs=0.5)        # start_delay (default 2)

    # Two more engines, started now and watched alongside it (each has its own sender): the stuck and
    # off-role thresholds, set while they watch, decide why they exclude robots (the next round,
    # assigned or aborted, says why).
    thresholds = {'stuck': {'problem_detection.stuck_time': 3.0, 'problem_detection.stuck_distance': 0.05},
                  'off_role': {'problem_detection.off_role_distance': 0.02, 'problem_detection.off_role_grace': 0.5}}
    for kind in thresholds:
        spec = engine_spec(settings_file, **PATIENT_ENGINE)
        spec.name = f'role_engine_{kind}'
        session.start(spec)
    for kind, values in thresholds.items():
        sender = f'/role_engine_{kind}'
        assigned = assignments.wait(lambda m: m.sender == sender and m.round == 1, 90, f"{sender}'s first round")
        assert assigned.status == 'assigned', assigned.message
        for parameter, value in values.items():
            assert set_one(session, sender, parameter, value).successful

    # No player runs: every robot falls silent after silence_timeout (default 4 s), and with none
    # left the task is aborted, naming min_robots as set.
    aborted = assignments.wait(lambda m: m.sender == ENGINE and m.round == first.round + 1, 90,
                               "the engine's second round")
    assert aborted.status == 'aborted'
    assert 'the formation needs min_robots = 2' in aborted.message
    quiet = [float(q) for q in re.findall(r'went silent \(no process role for ([0-9.]+) s\)', aborted.message)]
    assert len(quiet) == 4 and min(quiet) >= 6.0, aborted.message
    assert start_stamp(aborted) - start >= 6.0

    for kind in thresholds:
        sender = f'/role_engine_{kind}'
        ended = assignments.wait(lambda m: m.sender == sender and m.round == 2, 90, f"{sender}'s second round")
        expected = 'is stuck (moved' if kind == 'stuck' else 'is off its role ('
        assert ended.message.count(expected) >= 1 and 'went silent' not in ended.message, (kind, ended.message)


# ------------------------------------------------------------------------------------ role_player
class Heard:
    """pioneer_1's process roles (stamp, arrived) and commands, as they arrive."""

    def __init__(self, node, robot):
        self.lock = threading.Lock()
        self.roles, self.commands = [], []
        node.create_subscription(ProcessRole, '/roles/channel', lambda m: m.robot == robot and self._role(m), RELIABLE)
        node.create_subscription(Twist, f'/{robot}/cmd_vel', self._command, SENSOR_IN)

    def _role(self, msg):
        with self.lock:
            self.roles.append((start_stamp(msg), msg.arrived, msg.version))

    def _command(self, msg):
        with self.lock:
            self.commands.append((msg.linear.x, msg.angular.z))

    def take_commands(self):
        with self.lock:
            commands, self.commands = self.commands, []
        return commands

    def role_stamps(self, since=0):
        with self.lock:
            return [stamp for stamp, _, _ in self.roles[since:]]


def intervals(stamps):
    return [b - a for a, b in zip(stamps, stamps[1:])]


def test_role_player_applies_its_tuning_and_refuses_the_rest(session, settings_file):
    robot = 'pioneer_1'
    node = player_node(robot)
    task = load_formation_task(settings_file)
    heard = Heard(session.observer.node, robot)
    session.start(bridge_spec(task.scenario, real_time_factor=1.0, start_paused=False))
    session.start(engine_spec(settings_file, **PATIENT_ENGINE))
    session.start(tracker_spec())
    session.start(player_spec(robot, settings_file))
    session.wait_for_nodes([node], timeout=60.0)
    # The tuning is declared once the team description (its robot's limits) has come from the engine.
    wait_until(lambda: 'replan_period' in descriptors(session, node), 60, 'the tuning parameters')
    found = check_parameter_contract(session, node, PLAYER_TUNING, PLAYER_READ_ONLY)
    assert found['max_linear_velocity'].floating_point_range[0].to_value == pytest.approx(1.2)   # pioneer limit
    for name, value, reason in (('replan_period', 'fast', None), ('gp.max_iterations', 2.5, None),
                                ('max_linear_velocity', 5.0, None), ('speed_fraction', 1.5, None),
                                ('gp.formulation', 'magic', 'gp.formulation'),
                                ('robot_avoidance.detour_scales', [1.0, -2.0], 'detour_scales')):
        result = set_one(session, node, name, value)
        assert not result.successful, (name, value)
        assert reason is None or reason in result.reason, result.reason

    # Velocity caps: once it drives, its commands stay within them from the next command on (so it
    # cannot reach its point, about 2 m away, within its 20 s role).
    wait_until(lambda: any(abs(v) > 0.05 for v, _ in list(heard.commands)), 90, 'pioneer_1 driving')
    for name, value in (('max_linear_velocity', 0.03), ('max_angular_velocity', 0.2)):
        assert set_one(session, node, name, value).successful
    time.sleep(0.5)
    heard.take_commands()                                   # any still in flight from before the set
    wait_until(lambda: len(heard.commands) >= 20, 60, 'commands after the caps')
    commands = heard.take_commands()
    assert max(abs(v) for v, _ in commands) <= 0.03 + 1e-9
    assert max(abs(w) for _, w in commands) <= 0.2 + 1e-9
    assert any(v != 0.0 for v, _ in commands)

    # Re-plan period: the heartbeat on the channel (1 s from the settings file) follows it.
    wait_until(lambda: len(heard.role_stamps()) >= 5, 90, 'five process roles of pioneer_1')
    before = intervals(heard.role_stamps()[-4:])
    assert statistics.median(before) < 2.0, before
    assert set_one(session, node, 'replan_period', 3.0).successful
    mark = len(heard.role_stamps()) + 1                       # the first one may still be of the old period
    wait_until(lambda: len(heard.role_stamps(mark)) >= 4, 90, 'four process roles at the new period')
    after = intervals(heard.role_stamps(mark))
    assert statistics.median(after) > 2.5, after

    # The values that reach the re-plan and the controller (unit-tested there): applied, and it keeps re-planning.
    others = {'conflict_horizon': 6.0, 'speed_fraction': 0.5, 'controller.k_x': 1.2, 'controller.k_y': 6.0,
              'controller.k_theta': 2.5, 'controller.k_approach': 0.8, 'controller.k_turn': 1.5,
              'robot_avoidance.clearance': 0.15, 'robot_avoidance.sigma': 0.03, 'robot_avoidance.interpolation': 2,
              'robot_avoidance.detour_scales': [1.5], 'gp.epsilon': 0.12, 'gp.sigma_obs': 0.12,
              'gp.lambda_initial': 500.0, 'gp.max_iterations': 30, 'gp.relative_error_tol': 1e-3,
              'gp.obstacle_interpolation': 1, 'gp.formulation': 'vectorised', 'replan_period': 1.0}
    for name, value in others.items():
        result = set_one(session, node, name, value)
        assert result.successful, (name, result.reason)
    assert get_values(session, node, others) == others
    count = len(heard.role_stamps())
    wait_until(lambda: len(heard.role_stamps()) >= count + 3, 60, 're-plans with the new settings')

    # Arrival tolerance: with 5 m, the capped robot, far from its point, has arrived once its role is over.
    assert not any(arrived for _, arrived, _ in heard.roles)
    assert set_one(session, node, 'arrival_tolerance', 5.0).successful
    wait_until(lambda: any(arrived for _, arrived, _ in heard.roles), 120, 'the arrived report')
    assert 'Traceback' not in player_process(session, robot).log_path.read_text()

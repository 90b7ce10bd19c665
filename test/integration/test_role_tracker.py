"""robot_tracker: one camera subscription, one ``<team>/<robot>/tracked_pose`` per robot, close to ground truth.

The tracker takes the team from the role engine's latched /roles/team (it reads no file), tracks
every robot on the top camera and publishes PoseStamped poses stamped with the camera frame's
stamp. Checked against /ground_truth/bodies (interpolated at the pose's stamp) while one robot
drives; its colour thresholds are dynamic (a blob-size threshold above every robot's blob stops
the poses, setting it back brings them back), its camera and team namespace read-only. A role
player drives on these poses and stops its robot when they stop coming.
"""

import math
import threading
import time

import numpy as np
from bridge_interfaces.msg import BodyStates
from geometry_msgs.msg import PoseStamped, Twist
from rclpy.qos import ReliabilityPolicy

from collab_tools.qos import COMMAND_OUT, SENSOR_IN
from bridge_helpers import bridge_spec
from role_engine.core.formation_task import load_formation_task
from role_engine.core.node_settings import TRACKER_SETTINGS
from role_helpers import TRACKER, engine_spec, player_process, player_spec, tracker_spec
from parameter_client import check_parameter_contract, set_one
from test_role_parameters import PATIENT_ENGINE, wait_until

ROBOTS = ('pioneer_1', 'pioneer_2', 'burger_1', 'burger_2')
#: Position error allowed [m]: about a camera pixel (5.4 m / 320 px) plus the interpolation of the truth.
POSITION_TOLERANCE = 0.04


def stamp_of(msg) -> float:
    return msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9


def yaw_of(q) -> float:
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def angle_error(a: float, b: float) -> float:
    return abs((a - b + math.pi) % (2.0 * math.pi) - math.pi)


class Recorder:
    """Every tracked pose and ground-truth sample, as they arrive."""

    def __init__(self, node):
        self.lock = threading.Lock()
        self.poses = {robot: [] for robot in ROBOTS}
        self.truth = []                                  # (t, {robot: (x, y, yaw)})
        for robot in ROBOTS:
            node.create_subscription(PoseStamped, f'/{robot}/tracked_pose',
                                     lambda m, r=robot: self._pose(r, m), SENSOR_IN)
        node.create_subscription(BodyStates, '/ground_truth/bodies', self._truth, 10)

    def _pose(self, robot, msg):
        with self.lock:
            self.poses[robot].append(msg)

    def _truth(self, msg):
        sample = {b.name: (b.pose.position.x, b.pose.position.y, yaw_of(b.pose.orientation))
                  for b in msg.bodies if b.name in ROBOTS}
        with self.lock:
            self.truth.append((stamp_of(msg), sample))

    def count(self, robot):
        with self.lock:
            return len(self.poses[robot])

    def truth_at(self, t):
        """Ground truth (x, y, yaw) of every robot interpolated at time t (None outside the samples)."""
        with self.lock:
            truth = list(self.truth)
        times = np.array([s for s, _ in truth])
        k = int(np.searchsorted(times, t))
        if k == 0 or k >= len(times):
            return None
        (t0, a), (t1, b) = truth[k - 1], truth[k]
        w = (t - t0) / (t1 - t0) if t1 > t0 else 0.0
        return {r: (a[r][0] + w * (b[r][0] - a[r][0]), a[r][1] + w * (b[r][1] - a[r][1]), b[r][2]) for r in a}


def test_tracker_publishes_every_robot_close_to_ground_truth_and_applies_its_thresholds(session, config_dir):
    settings = config_dir / 'roles' / 'formation_demo.yaml'
    task = load_formation_task(settings)
    node = session.observer.node
    recorder = Recorder(node)
    session.start(bridge_spec(task.scenario, real_time_factor=1.0, start_paused=False, ground_truth_rate=50.0))
    session.start(engine_spec(settings, **PATIENT_ENGINE))           # the team's source (/roles/team)
    session.start(tracker_spec())
    session.wait_for_nodes([TRACKER], timeout=60.0)
    for robot in ROBOTS:
        wait_until(lambda r=robot: recorder.count(r) >= 5, 60, f'poses of {robot}')
    # One small best-effort publisher per robot, under the robot's namespace.
    for robot in ROBOTS:
        (info,) = node.get_publishers_info_by_topic(f'/{robot}/tracked_pose')
        assert info.node_name == 'robot_tracker' and info.qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT

    # pioneer_1 drives a curve: its poses follow the truth at their stamps.
    command = Twist()
    command.linear.x, command.angular.z = 0.3, 0.4
    cmd_pub = node.create_publisher(Twist, '/pioneer_1/cmd_vel', COMMAND_OUT)
    driver = node.create_timer(0.1, lambda: cmd_pub.publish(command))
    mark = recorder.count('pioneer_1')
    wait_until(lambda: recorder.count('pioneer_1') >= mark + 40, 60, '40 poses of the driving pioneer_1')
    node.destroy_timer(driver)
    cmd_pub.publish(Twist())
    time.sleep(0.5)                                         # truth after the last pose
    with recorder.lock:
        poses = {robot: list(msgs) for robot, msgs in recorder.poses.items()}
    moved = math.dist(*[(p.pose.position.x, p.pose.position.y) for p in (poses['pioneer_1'][mark],
                                                                          poses['pioneer_1'][-1])])
    assert moved > 0.5, f'pioneer_1 moved only {moved:.2f} m'
    worst = {}
    for robot, msgs in poses.items():
        errors, yaw_errors = [], []
        for msg in msgs[-30:]:
            assert msg.header.frame_id == 'world'
            truth = recorder.truth_at(stamp_of(msg))
            if truth is None:
                continue
            x, y, yaw = truth[robot]
            errors.append(math.dist((msg.pose.position.x, msg.pose.position.y), (x, y)))
            yaw_errors.append(angle_error(yaw_of(msg.pose.orientation), yaw))
        assert len(errors) >= 20, robot
        worst[robot] = (max(errors), max(yaw_errors))
    print('worst position / yaw error per robot:', {r: f'{p:.3f} m / {y:.2f} rad' for r, (p, y) in worst.items()})
    for robot, (position, yaw) in worst.items():
        assert position < POSITION_TOLERANCE, (robot, position)
        assert yaw < (0.2 if robot.startswith('pioneer') else 0.5), (robot, yaw)   # a burger's marker is ~2 px

    # Parameters: the thresholds are dynamic, the rest read-only; out-of-range values are refused.
    check_parameter_contract(session, TRACKER, [s.name for s in TRACKER_SETTINGS if s.dynamic], {'camera', 'team_namespace'})
    for name, value in (('min_area_px', 0), ('chroma_tolerance', 0.0), ('min_brightness', 800.0),
                        ('min_area_px', 2.5)):
        assert not set_one(session, TRACKER, name, value).successful, (name, value)
    # A blob threshold above every robot's blob: no robot is found, no pose is published ...
    assert set_one(session, TRACKER, 'min_area_px', 100000).successful
    time.sleep(1.0)                                          # poses of frames before the set
    counts = {robot: recorder.count(robot) for robot in ROBOTS}
    time.sleep(2.0)
    assert {robot: recorder.count(robot) for robot in ROBOTS} == counts
    # ... and set back, every robot is published again.
    assert set_one(session, TRACKER, 'min_area_px', 4).successful
    for robot in ROBOTS:
        wait_until(lambda r=robot: recorder.count(r) >= counts[r] + 5, 30, f'poses of {robot} again')
    log = session.nodes['robot_tracker'].log_path.read_text()
    assert 'min_area_px set to 100000' in log and 'Traceback' not in log



def test_a_player_without_fresh_poses_stops_its_robot(session, config_dir):
    """The player drives on the tracker's poses; when they stop coming (tracker gone) it stops the robot."""
    settings = config_dir / 'roles' / 'formation_demo.yaml'
    task = load_formation_task(settings)
    node = session.observer.node
    commands, lock = [], threading.Lock()

    def on_command(msg):
        with lock:
            commands.append(msg.linear.x)
    node.create_subscription(Twist, '/pioneer_1/cmd_vel', on_command, SENSOR_IN)
    session.start(bridge_spec(task.scenario, real_time_factor=1.0, start_paused=False))
    session.start(engine_spec(settings, **PATIENT_ENGINE))
    session.start(tracker_spec())
    session.start(player_spec('pioneer_1', settings))
    wait_until(lambda: any(abs(v) > 0.05 for v in list(commands)), 90, 'pioneer_1 driving')
    log_path = player_process(session, 'pioneer_1').log_path
    stopped = 'no tracked pose of pioneer_1 for 1 s: stopped'
    before = log_path.read_text().count(stopped)            # (a role that started before the first pose)
    session.stop('robot_tracker')
    # Its pose is older than POSE_TIMEOUT (1 s of ROS time): it says it stopped; every command from then on is 0.
    wait_until(lambda: log_path.read_text().count(stopped) > before, 30, 'the player to stop its robot')
    with lock:
        del commands[:]
    wait_until(lambda: len(commands) >= 3, 30, 'commands after the tracker stopped')
    assert all(v == 0.0 for v in list(commands))
    assert 'Traceback' not in log_path.read_text()

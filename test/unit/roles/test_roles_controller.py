"""Trajectory following for differential-drive robots with per-type limits."""
import math
from pathlib import Path

import numpy as np
import pytest

from pybullet_bridge.core import Scene, parse_scenario
from pybullet_bridge.core.scenario import BUILTIN_ROBOT_TYPES
from role_engine.core.astar import EMapPlanner
from role_engine.core.controller import TrackingGains, TrajectoryFollower
from role_engine.core.emap import build_emap
from role_engine.core.environment import RobotType, load_map_file
from role_engine.core.errors import RoleEngineError
from role_engine.core.initial_paths import emap_trajectory, polyline_trajectory

from roles_map_helpers import MAPS_DIR


def robot_type(name: str) -> RobotType:
    spec = BUILTIN_ROBOT_TYPES[name]
    return RobotType(name, spec['radius'], max_linear_velocity=spec['max_linear_velocity'],
                     max_angular_velocity=spec['max_angular_velocity'])


def simulate(follower: TrajectoryFollower, pose, duration: float, dt: float = 0.02):
    """Kinematic unicycle driven by the follower; returns poses, times and commands."""
    x, y, yaw = pose
    poses, times, commands = [], [], []
    for step in range(int(duration / dt)):
        t = step * dt
        v, w = follower.command(t, (x, y, yaw))
        commands.append((v, w))
        x, y, yaw = x + v * math.cos(yaw) * dt, y + v * math.sin(yaw) * dt, yaw + w * dt
        poses.append((x, y, yaw))
        times.append(t + dt)
    return np.array(poses), np.array(times), np.array(commands)


@pytest.mark.parametrize('name', ['turtlebot3_burger', 'pioneer_3dx'])
def test_follows_an_emap_role_within_the_type_limits(name):
    kind = robot_type(name)
    env = load_map_file(MAPS_DIR / 'env_1.yaml')
    planner = EMapPlanner(build_emap(env.for_robot(kind)))
    start, goal = (-2.2, -2.2), (2.2, 2.2)
    path = planner.plan(start, goal)
    total_time = path.length / (0.7 * kind.max_linear_velocity)
    states, _ = emap_trajectory(planner, start, goal, total_time, 60)
    follower = TrajectoryFollower(states, total_time, kind)
    heading = math.atan2(states[1, 1] - start[1], states[1, 0] - start[0])
    poses, times, commands = simulate(follower, (start[0], start[1], heading + 0.5), total_time + 5.0)
    assert np.abs(commands[:, 0]).max() <= kind.max_linear_velocity + 1e-12
    assert np.abs(commands[:, 1]).max() <= kind.max_angular_velocity + 1e-12
    errors = [math.dist(p[:2], follower.reference(t)[0]) for p, t in zip(poses, times)]
    settled = times > 3.0
    assert max(np.array(errors)[settled]) < 0.1
    assert math.dist(poses[-1, :2], goal) < 0.03 and follower.finished(times[-1], poses[-1])
    # The robot's centre stays clear of the obstacles inflated by its radius.
    assert env.for_robot(kind).sdf.distance(poses[:, :2]).min() > -0.03


def test_turns_around_when_the_role_points_behind_it():
    kind = robot_type('pioneer_3dx')
    states = polyline_trajectory(np.array([[0.0, 0.0], [2.0, 0.0]]), 5.0, 20)
    follower = TrajectoryFollower(states, 5.0, kind)
    poses, times, _ = simulate(follower, (0.0, 0.0, math.pi), 9.0)
    assert math.dist(poses[-1, :2], (2.0, 0.0)) < 0.03


def test_at_rest_it_approaches_the_end_point_and_stops():
    kind = robot_type('turtlebot3_burger')
    states = polyline_trajectory(np.array([[1.0, 1.0], [1.0, 1.0]]), 2.0, 4)
    follower = TrajectoryFollower(states, 2.0, kind)
    assert follower.command(0.0, (1.0, 1.01, 0.3)) == (0.0, 0.0)
    v, w = follower.command(0.0, (0.0, 1.0, math.pi / 2))
    assert w < 0 and v >= 0            # turn right toward +x first
    poses, _, _ = simulate(follower, (0.0, 1.0, math.pi / 2), 15.0)
    assert math.dist(poses[-1, :2], (1.0, 1.0)) < 0.03


def test_follows_a_role_in_the_bridge_simulation():
    kind = robot_type('turtlebot3_burger')
    # 1.86 m in 13 s: 0.14 m/s, two thirds of the Burger's top speed, with a 54 deg corner.
    states = polyline_trajectory(np.array([[-1.0, -1.0], [0.0, -1.0], [0.5, -0.3]]), 13.0, 40)
    follower = TrajectoryFollower(states, 13.0, kind)
    data = {'name': 'follow', 'world': {'bounds': [-2.0, -2.0, 2.0, 2.0]},
            'camera': {'width': 16, 'height': 16},
            'mobile_robots': [{'name': 'tb', 'type': 'turtlebot3_burger', 'pose': [-1.0, -1.0, 0.0],
                               'color': [0.1, 0.2, 0.9]}]}
    with Scene(parse_scenario(data, Path('.'))) as scene:
        robot = scene.entity('tb')
        errors = []
        while scene.sim_time < 15.0:
            pose = robot.pose2d(scene.client)
            errors.append(math.dist(pose[:2], follower.reference(scene.sim_time)[0]))
            robot.set_command(*follower.command(scene.sim_time, pose), scene.sim_time)
            scene.step(12)                              # 20 Hz control
        final = robot.pose2d(scene.client)
    assert max(errors) < 0.06
    assert math.dist(final[:2], (0.5, -0.3)) < 0.03


def test_bad_arguments():
    states = polyline_trajectory(np.array([[0.0, 0.0], [1.0, 0.0]]), 1.0, 2)
    kind = robot_type('pioneer_3dx')
    with pytest.raises(RoleEngineError, match='total_time'):
        TrajectoryFollower(states, -1.0, kind)
    with pytest.raises(RoleEngineError, match='gains.k_y'):
        TrackingGains(k_y=0.0)
    with pytest.raises(RoleEngineError, match='finite'):
        TrajectoryFollower(states, 1.0, kind).command(0.0, (math.nan, 0.0, 0.0))


def rounded_corner_role(speed: float = 0.25, radius: float = 0.3, states: int = 41):
    """1 m along +x, a quarter circle of ``radius`` to the left, 1 m along +y, at constant ``speed``:
    (states, total_time, dense path points)."""
    arc = math.pi * radius / 2.0
    length = 2.0 + arc

    def point(s):
        if s <= 1.0:
            return np.array([s, 0.0]), np.array([1.0, 0.0])
        if s <= 1.0 + arc:
            phi = (s - 1.0) / radius
            return (np.array([1.0 + radius * math.sin(phi), radius - radius * math.cos(phi)]),
                    np.array([math.cos(phi), math.sin(phi)]))
        return np.array([1.0 + radius, radius + (s - 1.0 - arc)]), np.array([0.0, 1.0])

    total = length / speed
    rows = []
    for k, s in enumerate(np.linspace(0.0, length, states)):
        p, tangent = point(s)
        v = tangent * speed if 0 < k < states - 1 else np.zeros(2)
        rows.append([*p, *v])
    dense = np.array([point(s)[0] for s in np.linspace(0.0, length, 2000)])
    return np.array(rows), total, dense


def distance_to_path(points: np.ndarray, dense: np.ndarray) -> np.ndarray:
    return np.min(np.hypot(points[:, None, 0] - dense[None, :, 0], points[:, None, 1] - dense[None, :, 1]), axis=1)


def test_a_lagging_robot_does_not_cut_the_corner():
    """The robot stands 0.3 m before the bend while the role's clock is 1.5 s (0.375 m) further on, round
    the bend (it was held up): it catches up along the path instead of steering at the clock's point
    across the inside of the bend, so it stays on the planned path (the GP's epsilon from the obstacles
    is kept) and still catches up. (Steering at the clock's point, Kanayama's law as such, leaves the
    path by 0.10 m here.)"""
    kind = robot_type('pioneer_3dx')
    states, total, dense = rounded_corner_role()
    follower = TrajectoryFollower(states, total, kind)
    held, lag = 0.7 / 0.25, 1.5                         # s along the role where the robot is; its lag
    (x, y), yaw, dt = follower.reference(held)[0], 0.0, 0.02
    points, errors = [], []
    for step in range(int((total - held - lag + 3.0) / dt)):
        t = held + lag + step * dt
        v, w = follower.command(t, (x, y, yaw))
        x, y, yaw = x + v * math.cos(yaw) * dt, y + v * math.sin(yaw) * dt, yaw + w * dt
        points.append((x, y))
        errors.append(math.dist((x, y), follower.reference(t + dt)[0]))
    deviation = distance_to_path(np.array(points), dense)
    assert deviation.max() < 0.02                       # the clock's point would pull it 0.1 m inside
    settled = np.array(errors)[int(4.0 / dt):]
    assert settled.max() < 0.05                         # and the 0.375 m lag is made up within 4 s
    assert math.dist(points[-1], dense[-1]) < 0.03


def test_a_lateral_offset_decays_without_zig_zag_under_camera_latency():
    """A straight corridor role; the robot starts 5 cm to the side and sees its pose 0.15 s late at 10 Hz
    (the top camera and its tracker). The offset decays without crossing the path by more than 1 cm."""
    kind = robot_type('pioneer_3dx')
    states = polyline_trajectory(np.array([[0.0, 0.0], [3.0, 0.0]]), 10.0, 40)
    follower = TrajectoryFollower(states, 10.0, kind)
    x, y, yaw, dt = 0.0, 0.05, 0.0, 0.01
    history = [(0.0, x, y, yaw)]
    command = (0.0, 0.0)
    lateral = []
    for step in range(int(9.0 / dt)):
        t = step * dt
        if step % 10 == 0:                              # a camera frame every 0.1 s, 0.15 s old
            seen = next(h for h in reversed(history) if h[0] <= max(t - 0.15, 0.0))
            command = follower.command(t, seen[1:])
        v, w = command
        x, y, yaw = x + v * math.cos(yaw) * dt, y + v * math.sin(yaw) * dt, yaw + w * dt
        history.append((t + dt, x, y, yaw))
        lateral.append(y)
    lateral = np.array(lateral)
    assert lateral.min() > -0.01                        # no overshoot across the centre line
    assert abs(lateral[-1]) < 0.005


def test_far_off_its_heading_the_robot_turns_in_place_first():
    """Beyond ALIGN_ANGLE of heading error the robot does not drive (an arc off the path, or backward)
    but turns toward its path, no faster than ROTATE_SPEED; below it, it drives."""
    from role_engine.core.controller import ALIGN_ANGLE, ROTATE_SPEED
    kind = robot_type('pioneer_3dx')
    states = polyline_trajectory(np.array([[0.0, 0.0], [2.0, 0.0]]), 5.0, 20)
    follower = TrajectoryFollower(states, 5.0, kind)
    for yaw in (ALIGN_ANGLE + 0.05, -(ALIGN_ANGLE + 0.05), 2.0, -3.0):
        linear, angular = TrajectoryFollower(states, 5.0, kind).command(1.0, (0.4, 0.0, yaw))
        assert linear == 0.0 and 0.0 < abs(angular) <= ROTATE_SPEED and np.sign(angular) == -np.sign(yaw)
    linear, _ = follower.command(1.0, (0.4, 0.0, ALIGN_ANGLE - 0.05))
    assert linear > 0.0
    # Turning round from facing backward, then catching up 0.5 m: 12 cm sideways at most (driving while
    # turning swept 23 cm), and the robot never backs up behind its start.
    poses, _, _ = simulate(follower, (0.0, 0.0, math.pi - 0.2), 9.0)
    assert np.abs(poses[:, 1]).max() < 0.15 and poses[:, 0].min() > -0.01
    assert math.dist(poses[-1, :2], (2.0, 0.0)) < 0.03


def test_a_saturated_turn_keeps_its_curvature():
    """When the tracking law asks for more than the robot's angular limit, the linear speed drops by
    the same factor: the robot drives the commanded arc slower instead of a wider one."""
    kind = RobotType('slow_turner', 0.2, max_linear_velocity=1.0, max_angular_velocity=0.3)
    states = polyline_trajectory(np.array([[0.0, 0.0], [2.0, 0.0]]), 4.0, 20)
    free = TrajectoryFollower(states, 4.0, RobotType('free', 0.2))
    capped = TrajectoryFollower(states, 4.0, kind)
    pose = (0.5, 0.15, 0.4)                         # left of the path, heading further left
    v_free, w_free = free.command(1.0, pose)
    v_cap, w_cap = capped.command(1.0, pose)
    assert abs(w_free) > 0.3 and w_cap == pytest.approx(math.copysign(0.3, w_free))
    assert v_cap / w_cap == pytest.approx(v_free / w_free)


def test_just_past_its_goal_the_robot_backs_up_steadily():
    """Overshot by 0.25 m with the goal straight behind: the robot backs up to it. Facing away, the
    bearing sits at +-pi and its sign flips with every noisy pose: turning round, the robot stood
    still, commanding left and right in turn."""
    kind = robot_type('pioneer_3dx')
    states = polyline_trajectory(np.array([[0.0, 0.0], [1.0, 0.0]]), 4.0, 20)
    follower = TrajectoryFollower(states, 4.0, kind)
    commands = [follower.command(6.0, (1.25, 0.0, yaw)) for yaw in (0.01, -0.01)]
    assert all(v < 0.0 for v, _ in commands)                      # backing up whichever way noise leans
    assert abs(commands[0][1] - commands[1][1]) < 0.1              # and no left/right flip
    poses, _, _ = simulate(follower, (1.25, 0.0, 0.0), 6.0)
    assert math.dist(poses[-1, :2], (1.0, 0.0)) <= follower.position_tolerance + 1e-9


def test_a_lagging_robot_catches_up_no_faster_than_it_can_stop_at_the_end():
    """The role is over and the robot 0.3 m short of its end: it may not drive faster than a stop at
    APPROACH_DECELERATION allows (it used to arrive at 1.5 x the role's speed and run past)."""
    from role_engine.core.controller import APPROACH_DECELERATION
    kind = robot_type('pioneer_3dx')
    states = polyline_trajectory(np.array([[0.0, 0.0], [2.0, 0.0]]), 4.0, 20)
    follower = TrajectoryFollower(states, 4.0, kind)
    linear, _ = follower.command(3.9, (1.7, 0.0, 0.0))
    assert 0.0 < linear <= math.sqrt(2.0 * APPROACH_DECELERATION * 0.3) + 1e-9


def test_facing_straight_away_the_turn_keeps_its_direction_through_pose_noise():
    """Path heading straight behind: the error's sign flips with every noisy yaw; the robot keeps
    turning the way it started instead of alternating (and standing still)."""
    kind = robot_type('pioneer_3dx')
    states = polyline_trajectory(np.array([[0.0, 0.0], [2.0, 0.0]]), 5.0, 20)
    follower = TrajectoryFollower(states, 5.0, kind)
    turns = [follower.command(1.0, (0.4, 0.0, math.pi + noise))[1] for noise in (0.05, -0.05, 0.08, -0.02, 0.03)]
    assert all(np.sign(w) == np.sign(turns[0]) and w != 0.0 for w in turns)


def test_a_role_that_overshoots_and_turns_back_still_brings_the_robot_to_its_end():
    """A re-plan that started fast runs 0.25 m past its goal and comes back (seen in pybullet). The robot,
    stopped near the turning point after the role's time with the path's heading flipping there,
    approaches the end point directly (backing up) instead of turning to and fro."""
    kind = robot_type('pioneer_3dx')
    # Along +y past the goal (0, -1.1) to (0, -0.85), then back down to it.
    points = np.array([[0.0, -1.6], [0.0, -1.1], [0.0, -0.85], [0.0, -1.1]])
    states = polyline_trajectory(points, 3.0, 30)
    follower = TrajectoryFollower(states, 3.0, kind)
    poses, _, _ = simulate(follower, (0.0, -0.85, math.pi / 2), 8.0)
    assert math.dist(poses[-1, :2], (0.0, -1.1)) <= 0.05

"""Scene physics: robots follow limited commands, stop at walls, reset cleanly."""
import math
from pathlib import Path

import numpy as np
import pybullet as p
import pytest

from bridge_core_helpers import robot, scenario_dict
from pybullet_bridge.core.mobile_robot import MobileRobot
from pybullet_bridge.core.scenario import parse_scenario
from pybullet_bridge.core.scene import Scene

COMMAND_PERIOD = 0.1  # s, like a 10 Hz teleop publisher


def make_scene(*robots, bounds=(-3.0, -3.0, 3.0, 3.0)) -> Scene:
    data = scenario_dict(mobile_robots=list(robots))
    data['world']['bounds'] = list(bounds)
    return Scene(parse_scenario(data, Path('.')))


@pytest.fixture
def scenes():
    """Collects scenes so every test closes its pybullet clients."""
    created = []
    yield created
    for scene in created:
        scene.close()


def drive(scene: Scene, bot: MobileRobot, linear: float, angular: float, duration: float) -> float:
    """Re-send the command every COMMAND_PERIOD for ``duration`` s; return the unwrapped yaw change."""
    steps_per_command = round(COMMAND_PERIOD / scene.physics_dt)
    turned = 0.0
    yaw = bot.pose2d(scene.client)[2]
    for _ in range(round(duration / COMMAND_PERIOD)):
        bot.set_command(linear, angular, scene.sim_time)
        scene.step(steps_per_command)
        new_yaw = bot.pose2d(scene.client)[2]
        turned += math.remainder(new_yaw - yaw, 2 * math.pi)
        yaw = new_yaw
    return turned


def ramped_distance(speed: float, acceleration: float, duration: float) -> float:
    """Distance covered from rest when accelerating at ``acceleration`` up to ``speed``."""
    ramp = speed / acceleration
    return speed * (duration - ramp / 2) if duration >= ramp else acceleration * duration ** 2 / 2


def test_forward_command_moves_along_heading_with_acceleration_ramp(scenes):
    yaw = 0.5
    scene = make_scene(robot(pose=[-1.0, -0.5, yaw]))
    scenes.append(scene)
    bot = scene.entity('robot_1')
    drive(scene, bot, 0.5, 0.0, 2.0)
    x, y, final_yaw = bot.pose2d(scene.client)
    expected = ramped_distance(0.5, bot.params.limits.max_linear_acceleration, 2.0)
    assert math.hypot(x + 1.0, y + 0.5) == pytest.approx(expected, abs=0.02)
    assert math.atan2(y + 0.5, x + 1.0) == pytest.approx(yaw, abs=0.01)
    assert final_yaw == pytest.approx(yaw, abs=0.01)
    assert bot.velocity() == pytest.approx((0.5, 0.0))


def test_command_above_limit_moves_at_max_speed(scenes):
    scene = make_scene(robot(pose=[-2.0, 0.0, 0.0]))
    scenes.append(scene)
    bot = scene.entity('robot_1')
    limits = bot.params.limits
    drive(scene, bot, 5.0, 0.0, 2.0)
    x, y, _ = bot.pose2d(scene.client)
    assert bot.commanded_velocity() == (limits.max_linear_velocity, 0.0)
    expected = ramped_distance(limits.max_linear_velocity, limits.max_linear_acceleration, 2.0)
    assert x + 2.0 == pytest.approx(expected, abs=0.03)
    assert y == pytest.approx(0.0, abs=0.01)


def test_backward_command_moves_against_heading(scenes):
    scene = make_scene(robot(pose=[0.0, 0.0, math.pi / 2]))
    scenes.append(scene)
    bot = scene.entity('robot_1')
    drive(scene, bot, -0.4, 0.0, 1.5)
    x, y, _ = bot.pose2d(scene.client)
    assert y == pytest.approx(-ramped_distance(0.4, 1.0, 1.5), abs=0.02)
    assert x == pytest.approx(0.0, abs=0.01)


def test_rotation_follows_command_and_its_limit(scenes):
    scene = make_scene(robot(name='slow', pose=[-1.0, 0.0, 0.0]),
                       robot(name='fast', type='turtlebot3_burger', pose=[1.0, 0.0, 0.0],
                             color=[0.1, 0.1, 0.9]))
    scenes.append(scene)
    slow, fast = scene.entity('slow'), scene.entity('fast')
    steps_per_command = round(COMMAND_PERIOD / scene.physics_dt)
    turned = {'slow': 0.0, 'fast': 0.0}
    for _ in range(20):  # 2 s
        before = {bot.name: bot.pose2d(scene.client)[2] for bot in (slow, fast)}
        slow.set_command(0.0, 1.0, scene.sim_time)
        fast.set_command(0.0, -50.0, scene.sim_time)  # far beyond the burger's 2.84 rad/s
        scene.step(steps_per_command)
        for bot in (slow, fast):
            turned[bot.name] += math.remainder(bot.pose2d(scene.client)[2] - before[bot.name], 2 * math.pi)
    assert turned['slow'] == pytest.approx(ramped_distance(1.0, 3.0, 2.0), abs=0.03)
    fast_limits = fast.params.limits
    assert turned['fast'] == pytest.approx(
        -ramped_distance(fast_limits.max_angular_velocity, fast_limits.max_angular_acceleration, 2.0), abs=0.05)
    for bot, start_x in ((slow, -1.0), (fast, 1.0)):  # turning in place
        x, y, _ = bot.pose2d(scene.client)
        assert (x, y) == pytest.approx((start_x, 0.0), abs=0.01)


def test_command_timeout_stops_the_robot(scenes):
    scene = make_scene(robot(pose=[0.0, 0.0, 0.0]))
    scenes.append(scene)
    bot = scene.entity('robot_1')
    timeout = bot.params.command_timeout
    bot.set_command(0.5, 0.0, scene.sim_time)  # sent once, never refreshed
    scene.step(round(1.5 / scene.physics_dt))
    assert bot.velocity() == (0.0, 0.0)
    x_stopped = bot.pose2d(scene.client)[0]
    # Accelerate for 0.5 s to 0.5 m/s, hold until the timeout, brake at 1 m/s^2.
    expected = 0.125 + 0.5 * (timeout - 0.5) + 0.125
    assert x_stopped == pytest.approx(expected, abs=0.02)
    scene.step(round(0.5 / scene.physics_dt))
    assert bot.pose2d(scene.client)[0] == pytest.approx(x_stopped, abs=1e-3)


def test_non_finite_command_is_rejected_and_previous_command_kept(scenes):
    scene = make_scene(robot())
    scenes.append(scene)
    bot = scene.entity('robot_1')
    bot.set_command(0.3, 0.2, 0.0)
    for bad in ((math.nan, 0.0), (0.0, math.inf), (-math.inf, math.nan)):
        with pytest.raises(ValueError, match='non-finite'):
            bot.set_command(*bad, 0.0)
    assert bot.commanded_velocity() == (0.3, 0.2)
    scene.step(round(0.3 / scene.physics_dt))
    assert bot.velocity() == pytest.approx((0.3, 0.2))


def test_robot_driven_into_wall_stops_at_the_wall(scenes):
    # 5 cm walls at x = 2; 1.2 m/s must neither tunnel through nor push the robot into them.
    scene = make_scene(robot(pose=[1.0, 0.0, 0.0]), bounds=(-2.0, -2.0, 2.0, 2.0))
    scenes.append(scene)
    bot = scene.entity('robot_1')
    drive(scene, bot, 5.0, 0.0, 3.0)
    x, y, yaw = bot.pose2d(scene.client)
    wall_face = 2.0
    assert x == pytest.approx(wall_face - bot.params.radius, abs=0.01)
    assert y == pytest.approx(0.0, abs=0.02)
    assert yaw == pytest.approx(0.0, abs=0.02)


def test_robots_stay_planar_and_upright_in_a_head_on_collision(scenes):
    scene = make_scene(robot(name='pioneer', pose=[-1.0, 0.0, 0.0]),
                       robot(name='burger', type='turtlebot3_burger', pose=[0.0, 0.05, math.pi],
                             color=[0.1, 0.9, 0.1]))
    scenes.append(scene)
    pioneer, burger = scene.entity('pioneer'), scene.entity('burger')
    worst_tilt = worst_lift = 0.0
    for _ in range(20):  # 2 s: they meet at speed and the pioneer shoves the burger aside
        pioneer.set_command(5.0, 0.0, scene.sim_time)
        burger.set_command(5.0, 0.0, scene.sim_time)
        for _ in range(round(COMMAND_PERIOD / scene.physics_dt)):
            scene.step()
            for bot in (pioneer, burger):
                position, orientation = p.getBasePositionAndOrientation(bot.body_ids[0],
                                                                        physicsClientId=scene.client)
                roll, pitch, _ = p.getEulerFromQuaternion(orientation)
                worst_tilt = max(worst_tilt, abs(roll), abs(pitch))
                worst_lift = max(worst_lift, abs(position[2] - bot.params.height / 2))
    assert worst_tilt < 0.005 and worst_lift < 0.005
    # The lighter burger was shoved aside, not driven through.
    (px, py, _), (qx, qy, _) = pioneer.pose2d(scene.client), burger.pose2d(scene.client)
    assert qy > 0.2
    assert math.hypot(px - qx, py - qy) >= pioneer.params.radius + burger.params.radius - 0.01


def test_reset_restores_initial_poses_and_time(scenes):
    scene = make_scene(robot(pose=[0.5, -0.5, 1.0]))
    scenes.append(scene)
    bot = scene.entity('robot_1')
    drive(scene, bot, 0.8, 1.0, 1.0)
    assert scene.sim_time > 0.9
    assert bot.pose2d(scene.client)[:2] != pytest.approx((0.5, -0.5), abs=0.05)
    scene.reset()
    assert scene.sim_time == 0.0 and scene.step_count == 0
    assert scene.entity('robot_1') is bot  # callers' references stay valid
    assert bot.pose2d(scene.client) == pytest.approx((0.5, -0.5, 1.0), abs=1e-6)
    assert bot.velocity() == (0.0, 0.0)
    scene.step(10)
    assert bot.pose2d(scene.client) == pytest.approx((0.5, -0.5, 1.0), abs=1e-3)


def test_reset_with_new_scenario_replaces_entities(scenes):
    scene = make_scene(robot())
    scenes.append(scene)
    other = parse_scenario(scenario_dict(mobile_robots=[robot(name='other', pose=[1.0, 1.0, 0.0])]), Path('.'))
    scene.reset(other)
    assert [name for _, name, _ in scene.label_legend()] == ['walls', 'other']
    with pytest.raises(KeyError, match='known: walls, other'):
        scene.entity('robot_1')


def test_body_states_and_legend_cover_every_entity(scenes):
    scene = make_scene(robot(), robot(name='robot_2', pose=[1.0, 1.0, 0.0], color=[0.1, 0.1, 0.9]))
    scenes.append(scene)
    legend = scene.label_legend()
    assert legend == [(1, 'walls', 'wall'), (2, 'robot_1', 'mobile_robot'), (3, 'robot_2', 'mobile_robot')]
    states = {state.name: state for state in scene.body_states()}
    assert states.keys() == {'walls', 'robot_1', 'robot_2'}
    assert states['robot_2'].label == 3
    assert states['robot_2'].position[:2] == pytest.approx((1.0, 1.0))
    assert np.isclose(np.linalg.norm(states['robot_2'].orientation_xyzw), 1.0)
    assert scene.entities_of(MobileRobot) == [scene.entity('robot_1'), scene.entity('robot_2')]


def test_scenes_use_separate_clients(scenes):
    first, second = make_scene(robot()), make_scene(robot())
    scenes.extend([first, second])
    assert first.client != second.client
    drive(first, first.entity('robot_1'), 0.5, 0.0, 0.5)
    assert second.entity('robot_1').pose2d(second.client)[0] == pytest.approx(0.0, abs=1e-6)

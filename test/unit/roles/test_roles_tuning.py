"""The role nodes' tuning values (core.tuning): defaults from the settings file, validated changes,
and each value reaching what the node builds from it (the re-plan's GP settings and avoidance, the
controller, the problem watch)."""

import math

import numpy as np
import pytest

from role_engine.core.environment import RobotType
from role_engine.core.formation_task import load_formation_task
from role_engine.core.initial_paths import polyline_trajectory
from role_engine.core.tuning import EngineTuning, PlayerTuning

BURGER = RobotType('burger', 0.105, 0.03, max_linear_velocity=0.22, max_angular_velocity=2.84)


@pytest.fixture
def task(config_dir):
    return load_formation_task(config_dir / 'roles' / 'formation_demo.yaml')


def test_player_defaults_are_the_settings_file_and_the_robot_type_limits(task):
    tuning = PlayerTuning.from_task(task, BURGER)
    values = tuning.values()
    assert values['replan_period'] == task.replan_period
    assert values['arrival_tolerance'] == task.arrival_tolerance
    assert values['conflict_horizon'] == task.conflict_horizon
    assert values['controller.k_y'] == task.controller.k_y
    assert values['robot_avoidance.detour_scales'] == list(task.robot_avoidance.detour_scales)
    assert values['gp.sigma_obs'] == task.gp['sigma_obs'] and values['gp.max_iterations'] == task.gp['max_iterations']
    assert (values['max_linear_velocity'], values['max_angular_velocity']) == (0.22, 2.84)
    # Parameter types follow the values: floats stay floats, counts ints, the formulation a string.
    assert isinstance(values['gp.epsilon'], float) and isinstance(values['gp.max_iterations'], int)
    assert isinstance(values['robot_avoidance.interpolation'], int) and values['gp.formulation'] == 'compiled'
    # Without a change the GP settings of a re-plan are the team-wide ones.
    assert tuning.gp_config() == task.gp_config(BURGER)


def test_every_player_value_reaches_what_the_node_builds(task):
    tuning = PlayerTuning.from_task(task, BURGER)
    changed = tuning.with_values({
        'replan_period': 0.5, 'arrival_tolerance': 0.2, 'conflict_horizon': 6.0, 'speed_fraction': 0.5,
        'max_linear_velocity': 0.1, 'max_angular_velocity': 1.0, 'controller.k_x': 0.7, 'controller.k_y': 4.0,
        'controller.k_theta': 1.0, 'controller.k_approach': 0.3, 'controller.k_turn': 0.9,
        'robot_avoidance.clearance': 0.3, 'robot_avoidance.sigma': 0.05, 'robot_avoidance.interpolation': 1,
        'robot_avoidance.detour_scales': [0.0, 1.5], 'gp.epsilon': 0.2, 'gp.sigma_obs': 0.3,
        'gp.lambda_initial': 10.0, 'gp.max_iterations': 7, 'gp.relative_error_tol': 0.01,
        'gp.obstacle_interpolation': 2, 'gp.formulation': 'gtsam'})
    before, after = tuning.values(), changed.values()
    assert [name for name in before if before[name] == after[name]] == []   # every tuning value changed
    assert (changed.replan_period, changed.conflict_horizon) == (0.5, 6.0)
    gp = changed.gp_config()
    assert gp.max_speed == pytest.approx(0.5 * 0.1)        # speed_fraction x the velocity cap
    assert (gp.epsilon, gp.sigma_obs, gp.lambda_initial, gp.max_iterations, gp.relative_error_tol,
            gp.obstacle_interpolation, gp.formulation) == (0.2, 0.3, 10.0, 7, 0.01, 2, 'gtsam')
    assert gp.qc == task.gp_config(BURGER).qc              # the GP model constants stay team-wide
    avoidance = changed.avoidance
    assert (avoidance.clearance, avoidance.sigma, avoidance.interpolation, avoidance.detour_scales) == \
        (0.3, 0.05, 1, (1.5,))
    follower = changed.follower(polyline_trajectory(np.array([[0.0, 0.0], [2.0, 0.0]]), 4.0, 10), 4.0)
    assert follower.position_tolerance == pytest.approx(0.1)
    assert (follower.gains.k_x, follower.gains.k_y, follower.gains.k_theta, follower.gains.k_approach,
            follower.gains.k_turn) == (0.7, 4.0, 1.0, 0.3, 0.9)
    assert tuning.values()['replan_period'] == task.replan_period   # the original is unchanged


def test_the_velocity_caps_clamp_the_commands(task):
    trajectory = polyline_trajectory(np.array([[0.0, 0.0], [2.0, 0.0]]), 4.0, 10)
    tuning = PlayerTuning.from_task(task, BURGER)
    behind = (-0.5, 0.0, 0.0)                               # on the path, behind its clock: catches up
    beside = (-0.5, 0.3, 0.6)                               # beside it and turned away: a hard turn back
    capped = tuning.with_values({'max_linear_velocity': 0.05, 'max_angular_velocity': 0.5})
    assert tuning.follower(trajectory, 4.0).command(1.0, behind) == (0.22, 0.0)
    assert capped.follower(trajectory, 4.0).command(1.0, behind) == (0.05, 0.0)
    # A saturated turn keeps its curvature (the robot slows down on the same arc), under either cap.
    for limits, (cap_v, cap_w) in ((tuning, (0.22, 2.84)), (capped, (0.05, 0.5))):
        linear, angular = limits.follower(trajectory, 4.0).command(1.0, beside)
        assert abs(angular) == cap_w and 0.0 < linear < cap_v


def test_no_detour_is_zero_scales(task):
    tuning = PlayerTuning.from_task(task, BURGER).with_values({'robot_avoidance.detour_scales': [0.0]})
    assert tuning.avoidance.detour_scales == ()
    assert tuning.values()['robot_avoidance.detour_scales'] == [0.0]


@pytest.mark.parametrize('change, message', [
    ({'replan_period': 0.0}, 'replan_period: must be > 0'),
    ({'speed_fraction': 1.5}, r'speed_fraction: must be in \(0, 1\]'),
    ({'max_linear_velocity': 0.5}, 'max_linear_velocity: must be <= the burger limit 0.22'),
    ({'controller.k_turn': 0.0}, 'controller.k_turn: must be'),
    ({'robot_avoidance.sigma': 0.0}, 'robot_avoidance.sigma: must be > 0'),
    ({'robot_avoidance.detour_scales': [1.0, -1.0]}, r'robot_avoidance.detour_scales\[1\]: must be >= 0'),
    ({'gp.max_iterations': 0}, 'gp.max_iterations: must be >= 1'),
    ({'gp.formulation': 'magic'}, 'gp.formulation: must be one of vectorised, gtsam'),
    ({'gp.qc': 2.0}, 'gp.qc: not a tuning value of a role player'),
    ({'robot': 'burger_2'}, 'robot: not a tuning value'),
])
def test_bad_player_values_name_the_value(task, change, message):
    with pytest.raises(ValueError, match=message):
        PlayerTuning.from_task(task, BURGER).with_values(change)


def test_every_engine_value_reaches_the_negotiation_or_the_problem_watch(task):
    tuning = EngineTuning.from_task(task)
    assert tuning.values() == {
        'start_delay': task.start_delay, 'qualification_lambda': task.qualification_lambda,
        'min_robots': task.min_robots, 'silence_timeout': task.silence_timeout,
        **{f'problem_detection.{k}': getattr(task.problem_detection, k)
           for k in ('stuck_distance', 'stuck_time', 'off_role_distance', 'off_role_grace')}}
    changed = tuning.with_values({'start_delay': 5.0, 'qualification_lambda': 0.5, 'min_robots': 2,
                                  'silence_timeout': 9.0, 'problem_detection.stuck_distance': 0.2,
                                  'problem_detection.stuck_time': 3.0, 'problem_detection.off_role_distance': 1.0,
                                  'problem_detection.off_role_grace': 0.0})
    assert (changed.start_delay, changed.qualification_lambda, changed.min_robots) == (5.0, 0.5, 2)
    p = changed.problems
    assert (p.silence_timeout, p.stuck_distance, p.stuck_time, p.off_role_distance, p.off_role_grace) == \
        (9.0, 0.2, 3.0, 1.0, 0.0)
    for bad, message in (({'min_robots': 0}, 'min_robots: must be >= 1'),
                         ({'silence_timeout': -1.0}, 'silence_timeout: must be > 0'),
                         ({'problem_detection.stuck_time': 0.0}, 'problem_detection.stuck_time: must be > 0'),
                         ({'exit_when_done': True}, 'exit_when_done: not a tuning value')):
        with pytest.raises(ValueError, match=message):
            tuning.with_values(bad)
    assert math.isfinite(tuning.problems.silence_timeout)


def test_controller_gains_come_from_the_settings_file(tmp_path, config_dir):
    import yaml
    data = yaml.safe_load((config_dir / 'roles' / 'formation_demo.yaml').read_text())
    data['scenario'] = str(config_dir / 'scenarios' / 'roles_formation.yaml')
    data['controller'] = {'k_x': 2.5}
    path = tmp_path / 'settings.yaml'
    path.write_text(yaml.safe_dump(data))
    task = load_formation_task(path)
    assert (task.controller.k_x, task.controller.k_y) == (2.5, 20.0)   # the others keep their defaults
    data['controller'] = {'k_x': -1.0}
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ValueError, match='controller.k_x'):
        load_formation_task(path)
    data['controller'] = {'k_z': 1.0}
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ValueError, match='controller.k_z'):
        load_formation_task(path)

"""The role nodes' settings, silence detection and re-planning step (core.formation_task)."""

import numpy as np
import pytest

from role_engine.core.conflict import SharedRole
from role_engine.core.environment import Environment, RobotType
from role_engine.core.formation_task import load_formation_task, replan_process_role
from role_engine.core.initial_paths import polyline_trajectory


def test_demo_settings_give_one_diamond_point_per_robot(config_dir):
    task = load_formation_task(config_dir / 'roles' / 'formation_demo.yaml')
    roles = task.roles(4)
    assert [r.name for r in roles] == ['diamond_0', 'diamond_1', 'diamond_2', 'diamond_3']
    assert np.allclose([r.destination for r in roles], [[1.1, 0], [0, 1.1], [-1.1, 0], [0, -1.1]])
    assert len(task.roles(3)) == 3
    burger = RobotType('burger', 0.105, max_linear_velocity=0.22)
    assert task.gp_config(burger).max_speed == pytest.approx(task.speed_fraction * 0.22)


@pytest.mark.parametrize('edit, message', [
    ({'speed_fraction': 1.5}, 'speed_fraction'),
    ({'gp': {'max_speed': 1.0}}, 'gp.max_speed: unknown field'),
    ({'formation': {'type': 'hexagon', 'center': [0, 0], 'size': 1.0}}, "unknown formation 'hexagon'"),
    ({'scenario': 'missing.yaml'}, 'scenario'),
])
def test_bad_settings_name_the_field(tmp_path, config_dir, edit, message):
    import yaml
    data = yaml.safe_load((config_dir / 'roles' / 'formation_demo.yaml').read_text())
    data['scenario'] = str(config_dir / 'scenarios' / 'roles_formation.yaml')
    data.update(edit)
    path = tmp_path / 'settings.yaml'
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ValueError, match=message):
        load_formation_task(path)


def test_a_player_reads_the_settings_without_the_scenario(tmp_path, config_dir):
    """A role player's host may lack the scenario (the team comes over ROS): only the engine checks it."""
    import yaml
    data = yaml.safe_load((config_dir / 'roles' / 'formation_demo.yaml').read_text())
    data['scenario'] = 'missing.yaml'
    path = tmp_path / 'settings.yaml'
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ValueError, match="scenario file '.*missing.yaml' does not exist"):
        load_formation_task(path)
    task = load_formation_task(path, check_scenario=False)
    assert task.scenario == tmp_path / 'missing.yaml' and task.replan_period == data['replan_period']


def test_replan_sees_the_crossing_robot_and_keeps_start_goal_and_timing():
    environment = Environment(np.zeros((80, 80), dtype=bool), 0.05, (-2.0, -2.0))
    robot_type = RobotType('small', 0.1, max_linear_velocity=1.0)
    robot_env = environment.for_robot(robot_type)
    own = SharedRole('me', polyline_trajectory(np.array([[-1.5, 0.0], [1.5, 0.0]]), 10.0, 20), 10.0, 0.1)
    other = SharedRole('you', polyline_trajectory(np.array([[0.0, -1.5], [0.0, 1.5]]), 10.0, 20), 10.0, 0.1)
    from role_engine.core.gp_planner import GPPlannerConfig
    config = GPPlannerConfig(sigma_obs=0.05, epsilon=0.1, lambda_initial=1000.0, max_speed=1.0)
    result = replan_process_role(config, robot_env, own, [other], 2.0, (-0.9, 0.0), horizon=6.0)
    assert result.conflicting == ['you']
    assert result.start_time == 2.0 and result.total_time == pytest.approx(8.0)
    assert np.allclose(result.trajectory[0, :2], [-0.9, 0.0], atol=1e-3)
    assert np.allclose(result.trajectory[-1], [1.5, 0.0, 0.0, 0.0], atol=1e-3)
    # Nearly at the end of the role nothing is re-optimised.
    assert replan_process_role(config, robot_env, own, [other], 9.5, (1.4, 0.0), horizon=6.0).trajectory is None

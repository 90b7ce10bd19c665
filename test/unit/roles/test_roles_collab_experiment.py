"""roles-collab: settings, the scenario's map, the measures and the core-level simulation loop."""
from pathlib import Path

import numpy as np
import pytest

from pybullet_bridge.core.scenario import load_scenario

from role_engine.core import player
from role_engine.experiments.collab import run_measures
from role_engine.experiments.collab_config import load_collab_config
from role_engine.experiments.collab_simulation import initial_process_roles, scenario_team, simulate
from role_engine.experiments.path_measures import (contact_onsets, finite_difference_jerk, hermite_jerk,
                                                   separation_measures)
from role_engine.core.conflict import SharedRole
from role_engine.core.environment import environment_from_scenario

CONFIG = Path(__file__).resolve().parents[3] / 'config'

SCENARIO = """\
name: tiny
world: {bounds: [-1.5, -1.0, 1.5, 1.0], walls: {height: 0.3, thickness: 0.05}}
mobile_robots:
  - {name: west, type: turtlebot3_burger, pose: [-1.0, 0.0, 0.0], color: [0.9, 0.1, 0.1]}
  - {name: east, type: turtlebot3_burger, pose: [1.0, 0.6, 3.14159], color: [0.1, 0.1, 0.9]}
obstacles:
  boxes:
    - {name: rotated, center: [0.0, -0.6], size: [0.6, 0.2], height: 0.3, yaw: 0.7853982}
"""
TASK = """\
scenario: scenario.yaml
formation: {type: line, center: [0.0, 0.0], length: 2.0}
trajectory: {total_time: 12.0, states: 13}
grid_resolution: 0.05
gp: {sigma_obs: 0.1, epsilon: 0.05, lambda_initial: 1000.0, max_iterations: 20}
replan_period: 1.0
"""


def write_config(tmp_path: Path, collab: str) -> Path:
    (tmp_path / 'scenario.yaml').write_text(SCENARIO)
    (tmp_path / 'task.yaml').write_text(TASK)
    (tmp_path / 'collab.yaml').write_text(collab)
    return tmp_path / 'collab.yaml'


GOALS = """\
scenarios:
  - name: cross
    task: task.yaml
    goals: {west: [1.0, -0.2], east: [-1.0, 0.6]}
"""


def test_the_workspace_settings_load():
    config = load_collab_config(CONFIG / 'roles' / 'collab.yaml')
    assert config.methods == ('task_based', 'role_based')
    names = [s.name for s in config.scenarios]
    assert names == ['four_robots', 'hallway_swap', 'four_robots_swap']
    assert config.scenarios[1].goals == {'burger_west': (2.0, 0.0), 'burger_east': (-2.0, 0.0)}


@pytest.mark.parametrize('text, field', [
    ('methods: [task_based, selfish]\n' + GOALS, 'methods[1]'),
    ('control_rate: 0\n' + GOALS, 'control_rate'),
    ('scenarios: []\n', 'scenarios'),
    ('unknown: 1\n' + GOALS, 'unknown'),
    ('scenarios:\n  - {name: x, task: missing.yaml}\n', 'scenarios[0].task'),
    ('scenarios:\n  - {name: x, task: task.yaml, goals: {west: [1.0]}}\n', 'goals.west'),
])
def test_bad_settings_name_the_field(tmp_path, text, field):
    path = write_config(tmp_path, text)
    with pytest.raises(ValueError, match=field.replace('[', r'\[').replace(']', r'\]')):
        load_collab_config(path)


def test_goals_must_cover_exactly_the_robots(tmp_path):
    only_west = 'scenarios:\n  - {name: x, task: task.yaml, goals: {west: [1, 0]}}\n'
    config = load_collab_config(write_config(tmp_path, only_west))
    scenario = config.scenarios[0]
    bridge, team = scenario_team(scenario.task)
    with pytest.raises(ValueError, match=r"goals: .*missing: \['east'\]"):
        initial_process_roles(scenario, environment_from_scenario(bridge, 0.05), team)


def test_boxes_are_rasterised_with_their_yaw(tmp_path):
    write_config(tmp_path, GOALS)
    environment = environment_from_scenario(load_scenario(tmp_path / 'scenario.yaml'), 0.05)
    assert environment.shape == (40, 60) and environment.border_is_obstacle
    def occupied(x, y):
        return bool(environment.occupied[tuple(environment.frame.world_to_cell(np.array([[x, y]]))[0])])

    assert occupied(0.0, -0.6)
    assert occupied(0.17, -0.43) and occupied(-0.17, -0.77)       # along the box's 45 degree long axis
    assert not occupied(0.17, -0.77) and not occupied(0.25, -0.6)  # beside it: an axis-aligned box would cover these
    assert not occupied(0.0, 0.0)


def test_the_hallway_is_narrower_than_two_burgers_but_passable_by_one():
    scenario = load_scenario(CONFIG / 'roles' / 'hallway_scenario.yaml')
    environment = environment_from_scenario(scenario, 0.025)
    _, team = scenario_team(load_collab_config(CONFIG / 'roles' / 'collab.yaml').scenarios[1].task)
    burger = team[0].robot_type
    clearance = environment.sdf.distance(np.array([[0.0, 0.0]]))[0]
    assert burger.inflation < clearance < 2 * burger.radius      # one fits, two side by side do not
    view = environment.for_robot(burger)
    assert view.is_visitable((0.0, 0.0)) and not view.is_visitable((0.0, 0.1))


def test_contact_onsets_count_episodes():
    assert contact_onsets(np.array([0.5, 0.2, 0.1, 0.2, 0.5, 0.1, 0.5]), 0.3) == 2
    assert contact_onsets(np.array([0.1, 0.5]), 0.3) == 1           # starting in contact counts
    assert contact_onsets(np.array([0.3, 0.4]), 0.3) == 0           # touching is not overlapping


def test_separation_measures_on_known_positions():
    times = np.arange(3.0)
    positions = {'a': np.array([[0.0, 0.0], [0.0, 0.0], [0.0, 0.0]]),
                 'b': np.array([[1.0, 0.0], [0.25, 0.0], [1.0, 0.0]]),
                 'c': np.array([[0.0, 2.0], [0.0, 2.0], [0.0, 2.0]])}
    radii = {'a': 0.2, 'b': 0.1, 'c': 0.1}
    measures = separation_measures(positions, radii, times)
    assert measures['min_distance'] == pytest.approx(0.25) and measures['min_distance_pair'] == ['a', 'b']
    assert measures['min_distance_time'] == 1.0 and measures['sum_of_radii'] == pytest.approx(0.3)
    assert measures['min_clearance'] == pytest.approx(-0.05)
    assert measures['collisions'] == 1 and measures['collisions_by_pair'] == {'a-b': 1, 'a-c': 0, 'b-c': 0}


def test_jerk_of_a_cubic_motion():
    dt = 0.1
    t = np.arange(0.0, 2.0, dt)
    velocities = np.column_stack([3 * 0.5 * t**2, np.zeros_like(t)])     # x = 0.5 t^3: jerk 3
    np.testing.assert_allclose(finite_difference_jerk(velocities, dt), 3.0)
    # The Hermite interpolant of a cubic's states is that cubic: jerk 6 * 0.25 in y.
    times = np.linspace(0.0, 4.0, 5)
    states = np.column_stack([times, 0.25 * times**3, np.ones(5), 0.75 * times**2])
    role = SharedRole('r', states, 4.0, 0.1, start_time=10.0)
    assert hermite_jerk(role, 11.3) == pytest.approx(1.5)
    assert hermite_jerk(role, 9.0) == 0.0 and hermite_jerk(role, 15.0) == 0.0


def _run(tmp_path, method, monkeypatch=None):
    config = load_collab_config(write_config(tmp_path, GOALS))
    scenario = config.scenarios[0]
    bridge, team = scenario_team(scenario.task)
    environment = environment_from_scenario(bridge, scenario.task.grid_resolution)
    initial = initial_process_roles(scenario, environment, team)
    return config, team, environment, simulate(method, scenario.task, team, environment, initial, config)


def test_task_based_players_see_the_others_only_at_rest_where_they_are(tmp_path, monkeypatch):
    seen = []
    real = player.replan_process_role

    def spy(config, view, own, others, now, position, **kwargs):
        seen.append((own.name, now, others))
        return real(config, view, own, others, now, position, **kwargs)

    monkeypatch.setattr(player, 'replan_process_role', spy)   # the player the nodes run
    _, _, _, record = _run(tmp_path, 'task_based')
    assert seen
    for own, now, others in seen:
        (other,) = others
        assert other.name != own and other.start_time == now
        assert np.all(other.trajectory[:, 2:] == 0.0) and np.all(other.trajectory[0] == other.trajectory[-1])
        k = int(np.argmin(abs(record.times - now)))
        np.testing.assert_allclose(other.trajectory[0, :2], record.positions[other.name][k], atol=1e-9)


def test_role_based_players_see_the_others_process_roles(tmp_path, monkeypatch):
    seen = []
    real = player.replan_process_role

    def spy(config, view, own, others, now, position, **kwargs):
        seen.append(others)
        return real(config, view, own, others, now, position, **kwargs)

    monkeypatch.setattr(player, 'replan_process_role', spy)   # the player the nodes run
    _run(tmp_path, 'role_based')
    assert seen and all(len(o) == 1 and o[0].trajectory[:, 2:].any() for o in seen)   # moving roles


def test_a_simulated_run_arrives_and_is_measured(tmp_path):
    config, team, environment, record = _run(tmp_path, 'role_based')
    measures = run_measures(record, team, environment, 1.0 / config.control_rate)
    assert measures['completed'] and measures['completion_time'] >= 12.0
    for name, error in measures['final_error'].items():
        assert error <= 0.08, name
    assert measures['replans'] >= 2 * 10 and measures['replan_ms_median'] > 0
    assert measures['average_jerk'] > 0 and np.isfinite(measures['role_jerk'])
    with pytest.raises(ValueError, match='method'):
        simulate('selfish', config.scenarios[0].task, team, environment, {}, config)

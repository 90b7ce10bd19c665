"""Robot-obstacle clearance measured on driven tracks (experiments.path_measures.obstacle_clearances) and in
the roles-formation results from a recorded (synthetic) run."""
import math

import numpy as np
import pytest

from role_engine.experiments.formation import formation_acceptance, formation_markdown
from role_engine.experiments.formation_bag import formation_results, read_formation_bag
from role_engine.experiments.path_measures import ObstacleBox, obstacle_clearances

from test_roles_formation_experiment import RADII, typestore, write_bag  # noqa: F401 (fixture)


def test_signed_distance_of_a_rotated_box():
    box = ObstacleBox('b', (1.0, 0.0), (0.4, 0.2), math.pi / 2)      # 0.2 wide in x, 0.4 tall in y
    points = np.array([[1.0, 0.0], [1.3, 0.0], [1.0, 0.5], [1.3, 0.4], [1.05, 0.0]])
    np.testing.assert_allclose(box.signed_distance(points), [-0.1, 0.2, 0.3, math.hypot(0.2, 0.2), -0.05],
                               atol=1e-12)


def test_a_track_that_grazes_a_pillar_counts_one_contact_and_the_least_clearance():
    """A robot of radius 0.2 drives along y = 0 past a pillar whose lower face is at y = 0.19, out and back."""
    x = np.concatenate([np.linspace(-1.0, 1.0, 201), np.linspace(1.0, -1.0, 201)])
    times = np.arange(len(x)) * 0.1
    positions = {'a': np.column_stack([x, np.zeros_like(x)]), 'b': np.column_stack([x, np.full_like(x, -1.0)])}
    pillar = ObstacleBox('pillar', (0.0, 0.34), (0.3, 0.3))           # faces at y = 0.19 .. 0.49, x = +-0.15
    wall = ObstacleBox('wall', (0.0, -1.5), (4.0, 0.2))               # upper face at y = -1.4
    measured = obstacle_clearances(positions, {'a': 0.2, 'b': 0.1}, [pillar, wall], times)
    a, b = measured['obstacle_clearance']['a'], measured['obstacle_clearance']['b']
    assert a['min_clearance'] == pytest.approx(-0.01) and a['obstacle'] == 'pillar'
    assert a['contacts'] == 2                      # once passing out, once back
    assert abs(a['position'][0]) <= 0.15 + 1e-9
    assert b['min_clearance'] == pytest.approx(0.3) and b['obstacle'] == 'wall' and b['contacts'] == 0
    assert measured['min_obstacle_clearance'] == pytest.approx(-0.01)
    assert measured['min_obstacle_clearance_robot'] == 'a' and measured['obstacle_contacts'] == 2
    clear = obstacle_clearances(positions, {'a': 0.18, 'b': 0.1}, [pillar, wall], times)
    assert clear['obstacle_clearance']['a']['min_clearance'] == pytest.approx(0.01) and clear['obstacle_contacts'] == 0


def test_without_obstacles_nothing_is_measured():
    measured = obstacle_clearances({'a': np.zeros((3, 2))}, {'a': 0.1}, [], np.arange(3.0))
    assert measured['min_obstacle_clearance'] is None and measured['obstacle_contacts'] == 0


def test_formation_results_count_an_obstacle_contact_as_a_collision(tmp_path, typestore):  # noqa: F811
    """The synthetic run of test_roles_formation_experiment: a (r = 0.2) bulges to y = 0.3 at t = 7 s."""
    log = read_formation_bag(write_bag(tmp_path / 'bag', typestore, pass_gap=0.6), ['a', 'b'])
    far = [ObstacleBox('shelf', (0.0, 1.5), (0.5, 0.2))]             # lower face y = 1.4: a keeps 0.9 m
    results = formation_results(log, RADII, arrival_tolerance=0.08, obstacles=far)
    assert results['min_obstacle_clearance'] == pytest.approx(0.9, abs=1e-6)
    assert results['obstacle_contacts'] == 0 and results['collisions'] == 0
    assert formation_acceptance(results)['passed']
    near = [ObstacleBox('pillar', (0.0, 0.59), (0.2, 0.2))]           # lower face y = 0.49: a overlaps 1 cm
    results = formation_results(log, RADII, arrival_tolerance=0.08, obstacles=near)
    assert results['robots']['a']['min_obstacle_clearance'] == pytest.approx(-0.01, abs=1e-6)
    assert results['obstacle_clearance']['a']['time'] == pytest.approx(7.0)
    assert results['robot_collisions'] == 0 and results['obstacle_contacts'] == 1 and results['collisions'] == 1
    acceptance = formation_acceptance(results)
    assert not acceptance['passed']
    assert acceptance['checks']['no_collision'] is False
    assert acceptance['checks']['min_obstacle_clearance_positive'] is False
    report = formation_markdown(results, acceptance)
    assert '-10.0 mm' in report and '1 robot-obstacle' in report

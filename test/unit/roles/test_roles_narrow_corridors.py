"""Formation through narrow corridors at core level: the role players keep off the pillars.

The demo team (two Pioneers, r = 0.23 m, two Burgers) forms the diamond on the shipped pillar map
(config/maps/pillar_corridors.yaml: 0.625 m corridors, 8 cm per side for a centred Pioneer) with the
players of the nodes (core.player.RolePlayer) driving kinematic unicycles under the bridge's velocity
and acceleration limits (experiments.collab_simulation). Clearance is measured as roles-formation
measures it: the robot's true radius against the map's boxes and the walls. Before the fix the
Pioneers cut into the pillars by 3-10 cm here (re-plans chasing the tracking error, a sprint to the
old deadline, corner cutting after turns); the pybullet run of roles-formation is the end-to-end check.
"""
import dataclasses
import types

import numpy as np
import pytest
import yaml

from pybullet_bridge.core.robot_types import BUILTIN_ROBOT_TYPES
from role_engine.core.environment import environment_from_scenario
from role_engine.core.formation_task import load_formation_task
from role_engine.experiments.collab_simulation import initial_process_roles, scenario_team, simulate
from role_engine.experiments.formation_inputs import obstacle_boxes
from role_engine.experiments.path_measures import obstacle_clearances, separation_measures


def run_formation(config_dir, tmp_path, settings: str, map_file: str | None):
    task = load_formation_task(config_dir / 'roles' / settings)
    scenario = yaml.safe_load(task.scenario.read_text())
    if map_file is not None:
        scenario['obstacles'] = {'map': str(config_dir / 'maps' / map_file)}
    path = tmp_path / 'scenario.yaml'
    path.write_text(yaml.safe_dump(scenario))
    task = dataclasses.replace(task, scenario=path)
    bridge_scenario, team = scenario_team(task)
    environment = environment_from_scenario(bridge_scenario, task.grid_resolution)
    initial = initial_process_roles(types.SimpleNamespace(task=task, goals=None, name='corridors'), environment, team)
    config = types.SimpleNamespace(control_rate=20.0, integration_substeps=4, time_limit_factor=2.0)
    record = simulate('role_based', task, team, environment, initial, config)
    radii = {m.name: BUILTIN_ROBOT_TYPES[m.robot_type.name]['radius'] for m in team}
    clearance = obstacle_clearances(record.positions, radii, obstacle_boxes(bridge_scenario), record.times)
    return task, record, radii, clearance


@pytest.mark.parametrize('settings, map_file', [('formation_corridors.yaml', 'pillar_corridors.yaml'),
                                                ('formation_demo.yaml', None)])
def test_the_team_forms_without_touching_an_obstacle(config_dir, tmp_path, settings, map_file):
    task, record, radii, clearance = run_formation(config_dir, tmp_path, settings, map_file)
    late = {name: at for name, at in record.arrived_at.items() if at is None or at > 1.2 * task.total_time}
    assert not late, f'not arrived within 1.2 x the role time: {late}'
    assert clearance['obstacle_contacts'] == 0
    if map_file is not None:
        # The Pioneers keep more than a third of the 8 cm a centred Pioneer has in a corridor.
        assert clearance['min_obstacle_clearance'] > 0.03, clearance['obstacle_clearance']
    separation = separation_measures(record.positions, radii, record.times)
    assert separation['collisions'] == 0


def test_in_the_corridors_the_pioneers_do_not_zig_zag(config_dir, tmp_path):
    """Within a corridor between pillars a Pioneer's distance from the corridor's centre line stays
    small and does not swing from side to side (re-plans used to chase the tracking error)."""
    _, record, _, _ = run_formation(config_dir, tmp_path, 'formation_corridors.yaml', 'pillar_corridors.yaml')
    centres = np.array([-1.3875, -0.4625, 0.4625, 1.3875])
    lines = (centres[:-1] + centres[1:]) / 2.0                # corridor centre lines between the pillars
    for name in ('pioneer_1', 'pioneer_2'):
        points = record.positions[name]
        for axis in (0, 1):
            # Between pillars along the other axis: inside |other| within a pillar's extent.
            other = points[:, 1 - axis]
            inside = (np.any(np.abs(other[:, None] - centres[None, :]) < 0.15, axis=1)
                      & (points[:, axis] > centres[0]) & (points[:, axis] < centres[-1]))
            offsets = points[inside, axis][:, None] - lines[None, :]
            nearest = offsets[np.arange(len(offsets)), np.argmin(np.abs(offsets), axis=1)] if len(offsets) else []
            if len(nearest):
                assert np.abs(nearest).max() < 0.06, (name, axis, np.abs(nearest).max())

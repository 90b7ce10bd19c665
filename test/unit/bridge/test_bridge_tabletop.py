"""Tables with cell grids and the cubes on them (the ``tables`` and ``cubes`` sections)."""
from pathlib import Path

import numpy as np
import pybullet as p
import pytest

from bridge_core_helpers import SCENARIO_DIR, with_overrides
from pybullet_bridge.core.errors import ScenarioError
from pybullet_bridge.core.scenario import load_scenario, parse_scenario, registered_sections
from pybullet_bridge.core.scene import Scene
from pybullet_bridge.core.tabletop import Cube, Table

TABLE_TOP = 0.4

BASE = {
    'name': 'tabletop_unit',
    'world': {'bounds': [-1.0, -1.0, 1.0, 1.0]},
    'camera': {'width': 96, 'height': 96, 'altitude': 2.0, 'fov_deg': 12.0},
    'tables': [{'name': 'table', 'center': [0.0, 0.0], 'size': [0.3, 0.3], 'height': TABLE_TOP,
                'grid': {'rows': 3, 'cols': 3}}],
    'cubes': [{'name': 'red', 'position': [-0.1, 0.1], 'color': [0.9, 0.1, 0.1]},
              {'name': 'blue', 'position': [0.1, -0.1], 'size': 0.04, 'mass': 0.2, 'yaw': 0.3,
               'color': [0.1, 0.1, 0.9]}],
}


def tabletop(**overrides) -> dict:
    return with_overrides(BASE, **overrides)


def cube(**fields) -> dict:
    entry = {'name': 'c', 'position': [0.0, 0.0], 'color': [0.5, 0.5, 0.5]}
    entry.update(fields)
    return entry


def parse(data):
    return parse_scenario(data, Path('.'))


def test_sections_follow_obstacles_in_label_order():
    assert registered_sections()[:5] == ['mobile_robots', 'obstacles', 'tables', 'cubes', 'arms']


def test_cube_height_follows_the_table_under_it():
    data = tabletop()
    data['cubes'].append(cube(name='floor_cube', position=[0.6, 0.6], size=0.05))
    scenario = parse(data)
    [table] = scenario.sections['tables']
    red, blue, floor_cube = scenario.sections['cubes']
    assert (red.support, red.support_height, red.edge, red.mass) == ('table', TABLE_TOP, 0.03, 0.05)
    assert red.initial_z == pytest.approx(TABLE_TOP + 0.015)
    assert (blue.edge, blue.mass, blue.yaw) == (0.04, 0.2, 0.3)
    assert floor_cube.support is None and floor_cube.initial_z == pytest.approx(0.025)
    assert table.grid.rows == 3 and table.grid.line_width == pytest.approx(0.004)


def test_cells_are_numbered_like_image_pixels():
    table = parse(tabletop()).sections['tables'][0]
    assert table.cell_size == pytest.approx((0.1, 0.1))
    assert table.cell_region(0, 0) == pytest.approx((-0.15, 0.05, -0.05, 0.15))   # top-left of the image
    assert table.cell_region(2, 1) == pytest.approx((-0.05, -0.15, 0.05, -0.05))
    assert table.cell_at(0.12, -0.12) == (2, 2)
    assert table.cell_at(-0.15, 0.15) == (0, 0)   # edges belong to the table
    assert table.cell_at(0.2, 0.0) is None
    with pytest.raises(IndexError, match='3x3'):
        table.cell_region(3, 0)


@pytest.mark.parametrize('change, message', [
    (lambda d: d['cubes'].append(cube(position=[0.15, 0.0])),
     r"^cubes\[2\]\.position: cube footprint .* straddles the edge of table 'table'"),
    (lambda d: d['cubes'].append(cube(position=[5.0, 0.0])),
     r'^cubes\[2\]\.position: cube footprint .* is on no table and not inside world\.bounds'),
    (lambda d: d['cubes'].append(cube(position=[-0.09, 0.11])),
     r"^cubes\[2\]\.position: cube footprint .* overlaps cube 'red' \(cubes\[0\]\)"),
    (lambda d: d['cubes'].append(cube(name='red', position=[0.0, 0.0])),
     r"^cubes\[2\]\.name: duplicate name 'red' \(also used by cubes\[0\]\)"),
    (lambda d: d['cubes'].append(cube(name='table', position=[0.0, 0.0])),
     r"^cubes\[2\]\.name: duplicate name 'table' \(also used by tables\[0\]\)"),
    (lambda d: d['cubes'].append(cube(size=0.0)), r'^cubes\[2\]\.size: must be > 0\.0'),
    (lambda d: d['cubes'].append(cube(mass=-1)), r'^cubes\[2\]\.mass: must be > 0\.0'),
    (lambda d: d['cubes'].append(cube(colour=[1, 0, 0])), r'^cubes\[2\]\.colour: unknown field'),
    (lambda d: d['cubes'].append(cube(color=[1, 0])), r'^cubes\[2\]\.color: must be a list of 3 numbers'),
    (lambda d: d['cubes'][0].pop('position'), r'^cubes\[0\]\.position: missing required field'),
    (lambda d: d['tables'][0].update(height=0), r'^tables\[0\]\.height: must be > 0\.0'),
    (lambda d: d['tables'][0].update(size=[0.3]), r'^tables\[0\]\.size: must be a list of 2 numbers'),
    (lambda d: d['tables'][0].update(grid={'rows': 0, 'cols': 3}), r'^tables\[0\]\.grid\.rows: must be >= 1'),
    (lambda d: d['tables'][0].update(grid={'rows': 3}), r'^tables\[0\]\.grid\.cols: missing required field'),
    (lambda d: d['tables'][0].update(grid={'rows': 3, 'cols': 3, 'line_width': 0.06}),
     r'^tables\[0\]\.grid\.line_width: must be < half a cell'),
    (lambda d: d['tables'][0].update(center=[0.95, 0.0]),
     r'^tables\[0\]: table top .* must lie inside world\.bounds'),
    (lambda d: d['tables'].append({'name': 't2', 'center': [0.2, 0.0], 'size': [0.2, 0.2], 'height': 0.3}),
     r"^tables\[1\]: table 't2' overlaps table 'table' \(tables\[0\]\)"),
    (lambda d: d.update(obstacles={'boxes': [{'name': 'post', 'center': [0.6, 0.6], 'size': [0.1, 0.1],
                                              'height': 0.5}]}) or d['cubes'].append(cube(position=[0.6, 0.6])),
     r"^cubes\[2\]\.position: cube footprint .* overlaps obstacle 'post'"),
])
def test_invalid_tabletop_names_the_field(change, message):
    data = tabletop()
    change(data)
    with pytest.raises(ScenarioError, match=message):
        parse(data)


def test_a_cube_resting_on_a_grid_line_rests_on_the_table_top_and_stays_still():
    # x = -0.05 is a grid line between two cells: lines are visual only, so the cube rests on the top.
    data = tabletop()
    data['cubes'].append(cube(name='on_line', position=[-0.05, 0.0]))
    with Scene(parse(data)) as scene:
        bodies = {c.name: c.body_ids[0] for c in scene.entities_of(Cube)}
        start = {name: p.getBasePositionAndOrientation(body, physicsClientId=scene.client)
                 for name, body in bodies.items()}
        scene.step(round(2.0 / scene.physics_dt))
        for name, body in bodies.items():
            position, orientation = p.getBasePositionAndOrientation(body, physicsClientId=scene.client)
            edge = scene.entity(name).edge
            assert position[2] == pytest.approx(TABLE_TOP + edge / 2, abs=1e-3), name
            assert np.linalg.norm(np.subtract(position, start[name][0])) < 1e-4, name
            turn = p.getDifferenceQuaternion(orientation, start[name][1], physicsClientId=scene.client)
            assert abs(turn[3]) > np.cos(np.radians(0.5) / 2), name  # turned by less than 0.5 deg


def test_camera_sees_table_cells_and_cubes():
    with Scene(parse(tabletop())) as scene:
        legend = {name: label for label, name, _ in scene.label_legend()}
        frame = scene.render()
        table, red = scene.entity('table'), scene.entity('red')
        assert isinstance(table, Table) and isinstance(red, Cube)
        camera = scene.camera
        # The red cube is where the scenario put it, on its cell.
        u, v = (round(c) for c in camera.world_to_pixel(-0.1, 0.1, TABLE_TOP + red.edge))
        assert frame.labels[v, u] == legend['red']
        assert frame.rgb[v, u, 0] > 150 and frame.rgb[v, u, 2] < 80
        # A grid line between cells is dark and labelled as the table; the cell next to it is lighter.
        u_line, v_line = (round(c) for c in camera.world_to_pixel(0.05, -0.02, TABLE_TOP))
        u_cell, _ = (round(c) for c in camera.world_to_pixel(0.02, -0.02, TABLE_TOP))
        assert frame.labels[v_line, u_line] == legend['table']
        assert frame.rgb[v_line, u_line].sum() < 150 < frame.rgb[v_line, u_cell].sum()
        # The table fills the middle of the image; the ground shows around it.
        assert frame.labels[0, 0] == 0


def test_test_tabletop_scenario_loads():
    scenario = load_scenario(SCENARIO_DIR / 'test_tabletop.yaml')
    cubes = scenario.sections['cubes']
    assert len(cubes) == 6 and all(c.support == 'table' for c in cubes)
    assert {c.name.split('_')[0] for c in cubes} == {'red', 'green', 'blue'}
    [table] = scenario.sections['tables']
    assert (table.grid.rows, table.grid.cols) == (3, 3)
    assert [arm.model.name for arm in scenario.sections['arms']] == ['panda', 'kuka_iiwa']

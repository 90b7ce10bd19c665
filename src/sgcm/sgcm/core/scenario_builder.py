"""The bridge scenario of one case: a table with the cell grid, coloured cubes, two arms.

Produces the YAML mapping the pybullet bridge reads (sections tables, cubes, arms; see
pybullet_bridge/core/scenario.py). Cubes start on a 3 x 3 pattern of spots in their
cell, filled row by row. The arms face each other across the table along x: the leader
(a Panda) on -x, the follower (a KUKA iiwa) on +x, both within reach of every cell.
"""
from __future__ import annotations

import numpy as np

from .task_config import Case, TaskConfig

SPOTS_PER_SIDE = 3
ARM_DISTANCE = 0.565   # m from the table centre to each arm's base axis (reach checked by the bridge)
# Gap kept around a placed cube by the pixel test: 2.5 cm cubes + 5 mm fill a 0.10 m cell 3 x 3.
PLACEMENT_CLEARANCE = 0.005


def cube_spots(task: TaskConfig, cell: int) -> list[tuple[float, float]]:
    xmin, ymin, xmax, ymax = task.workspace.cell_region(task.rows, task.cols, cell)
    step = (xmax - xmin) / SPOTS_PER_SIDE
    return [(xmin + (i + 0.5) * step, ymax - (j + 0.5) * step)
            for j in range(SPOTS_PER_SIDE) for i in range(SPOTS_PER_SIDE)]


def build_scenario(task: TaskConfig, case: Case, name: str | None = None, seed: int = 0,
                   execution_failures: bool = True, camera_rate: float = 5.0) -> dict:
    ws = task.workspace
    if case.counts.sum(axis=1).max() > SPOTS_PER_SIDE ** 2:
        raise ValueError(f'case {case.name}: a cell holds more than {SPOTS_PER_SIDE ** 2} cubes')
    width = task.cols * ws.cell_size
    depth = task.rows * ws.cell_size
    cx, cy = ws.center
    cubes = []
    numbered = [0] * len(task.colours)
    for cell in range(task.cells):
        spots = iter(cube_spots(task, cell))
        for colour, count in enumerate(case.counts[cell]):
            for _ in range(int(count)):
                x, y = next(spots)
                numbered[colour] += 1
                cubes.append({'name': f'{task.colours[colour]}_{numbered[colour]}',
                              'position': [round(x, 4), round(y, 4)], 'size': ws.cube_size,
                              'color': list(task.colour_rgb[colour])})
    view = max(width, depth) * 1.3
    altitude = ws.table_height + 1.6
    fov = float(np.degrees(2 * np.arctan(view / 2 / (altitude - ws.table_height))))
    p_leader = task.leader.failure_probability if execution_failures else 0.0
    p_follower = task.follower.failure_probability if execution_failures else 0.0
    return {
        'name': name or f'sgcm_{case.name}',
        'seed': int(seed),
        'world': {'bounds': [cx - 1.0, cy - 1.0, cx + 1.0, cy + 1.0]},
        'camera': {'frame_id': 'top_camera', 'rate': camera_rate, 'width': 320, 'height': 320,
                   'center': [cx, cy], 'altitude': altitude, 'fov_deg': round(fov, 3)},
        'tables': [{'name': 'table', 'center': [cx, cy], 'size': [width, depth],
                    'height': ws.table_height, 'grid': {'rows': task.rows, 'cols': task.cols}}],
        'cubes': cubes,
        'arms': [
            {'name': 'leader_arm', 'model': 'panda', 'base': [cx - ARM_DISTANCE, cy, 0.0],
             'base_height': ws.table_height, 'failure_probability': p_leader,
             'placement_clearance': PLACEMENT_CLEARANCE},
            {'name': 'follower_arm', 'model': 'kuka_iiwa', 'base': [cx + ARM_DISTANCE, cy, float(np.pi)],
             'base_height': ws.table_height, 'failure_probability': p_follower,
             'placement_clearance': PLACEMENT_CLEARANCE},
        ],
    }

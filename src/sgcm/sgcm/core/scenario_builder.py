"""The bridge scenario of one case: a table with the cell grid, coloured cubes, two arms.

Produces the YAML mapping the pybullet bridge reads (sections tables, cubes, arms; see
pybullet_bridge/core/scenario.py). Cubes start on a 3 x 3 pattern of spots in their
cell, filled row by row. The arms stand where the task's workspace placed them
(:mod:`.workspace_layout`): facing each other across the table along ``arm_axis``, the leader
(a Panda) on the negative side, the follower (a KUKA iiwa) on the positive side. Placed from
the grid (the default), both reach every cell by the bridge's own arm models; with a fixed
``workspace.arm_distance`` an arm only gets the moves between cells it reaches
(rearrangement.ActionTable), so neither is ever asked for a move it cannot make.
"""
from __future__ import annotations

import numpy as np

from .task_config import Case, TaskConfig, TaskConfigError, task_of
from .workspace_layout import ARMS, PLACEMENT_CLEARANCE, SPOTS_PER_SIDE


def cube_spots(task: TaskConfig, cell: int) -> list[tuple[float, float]]:
    xmin, ymin, xmax, ymax = task.workspace.cell_region(task.rows, task.cols, cell)
    step = (xmax - xmin) / SPOTS_PER_SIDE
    return [(xmin + (i + 0.5) * step, ymax - (j + 0.5) * step)
            for j in range(SPOTS_PER_SIDE) for i in range(SPOTS_PER_SIDE)]


def build_scenario(task: TaskConfig, case: Case, name: str | None = None, seed: int = 0,
                   execution_failures: bool = True, camera_rate: float = 5.0) -> dict:
    """The scenario of ``case`` on its own task (its grid and goals when it has them, else ``task``)."""
    task = task_of(case, task)
    ws = task.workspace
    if task.cell_capacity > SPOTS_PER_SIDE ** 2:
        raise TaskConfigError(f'grid.cell_capacity: {task.cell_capacity} is more than the {SPOTS_PER_SIDE ** 2} '
                              f'cubes a simulated cell holds ({SPOTS_PER_SIDE} x {SPOTS_PER_SIDE} places); '
                              f'case {case.name} cannot be simulated')
    if case.counts.sum(axis=1).max() > SPOTS_PER_SIDE ** 2:
        raise TaskConfigError(f'case {case.name}: a cell holds more than {SPOTS_PER_SIDE ** 2} cubes '
                              f'(a simulated cell has {SPOTS_PER_SIDE} x {SPOTS_PER_SIDE} spots)')
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
    half = max(1.0, ws.arm_distance + max(model.pedestal_radius for _, model in ARMS) + 0.1)  # arms inside
    return {
        'name': name or f'sgcm_{case.name}',
        'seed': int(seed),
        'world': {'bounds': [cx - half, cy - half, cx + half, cy + half]},
        'camera': {'frame_id': 'top_camera', 'rate': camera_rate, 'width': 320, 'height': 320,
                   'center': [cx, cy], 'altitude': altitude, 'fov_deg': round(fov, 3)},
        'tables': [{'name': 'table', 'center': [cx, cy], 'size': [width, depth],
                    'height': ws.table_height, 'grid': {'rows': task.rows, 'cols': task.cols}}],
        'cubes': cubes,
        'arms': [
            {'name': arm_name, 'model': model.name, 'base': _base(ws.arm_base(robot)),
             'base_height': ws.table_height, 'failure_probability': p_fail,
             'placement_clearance': PLACEMENT_CLEARANCE}
            for robot, ((arm_name, model), p_fail) in enumerate(zip(ARMS, (p_leader, p_follower)))
        ],
    }


def _base(base: tuple[float, float, float]) -> list[float]:
    """[x, y, yaw] as the scenario writes it (the coordinates to the 0.1 mm)."""
    return [round(base[0], 4) + 0.0, round(base[1], 4) + 0.0, float(base[2])]

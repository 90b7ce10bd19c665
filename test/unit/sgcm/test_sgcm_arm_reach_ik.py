"""Issue 13: the placed set-ups hold up in the arms' own inverse kinematics, not only in the reach ring.

For grids of several shapes, the cell corners on the grid's border (where an arm's farthest and
nearest points and widest azimuths lie) are solved with the bridge's IK
(pybullet_bridge.core.arm.kinematics, as its planner does: top-down tool, grasp yaw from the
approach direction, from the home pose) at the place height (the grasp's plus a 3 mm drop gap)
and at the travel height 0.10 m above it; the planner rejects a goal whose key pose misses by
more than IK_TOLERANCE, and the arm models' reach was measured at 5 mm, the bound used here.
"""
import math

import numpy as np
import pybullet as p
import pytest

from pybullet_bridge.core.arm.kinematics import ArmKinematics, model_path, top_down_orientation
from pybullet_bridge.core.arm.models import grasp_yaw
from pybullet_bridge.core.arm.requests import CLEARANCE_HEIGHT, DROP_GAP, FLANGE_GAP
from sgcm.core.task_config import parse_task
from sgcm.core.workspace_layout import ARMS

from sgcm_tasks import small_task_data

#: The IK error below which the arm models' reach was measured (m); the planner allows IK_TOLERANCE.
REACH_IK_ERROR = 0.005
GRIDS = [(4, 4), (5, 3), (2, 6), (10, 1), (5, 5)]   # 3x3: the paper's set-up, run in simulation


@pytest.fixture(scope='module')
def kinematics():
    client = p.connect(p.DIRECT)
    solvers = []
    for _, model in ARMS:
        body = p.loadURDF(model_path(model), useFixedBase=True, physicsClientId=client)
        solvers.append(ArmKinematics(model, body, client))
    yield solvers
    p.disconnect(client)


@pytest.mark.parametrize('rows, cols', GRIDS)
def test_the_grid_border_solves_for_both_arms(kinematics, rows, cols):
    task = parse_task(small_task_data(rows, cols, {'red': [rows - 1, 0]}))
    ws = task.workspace
    xs = ws.center[0] + (np.arange(cols + 1) - cols / 2) * ws.cell_size
    ys = ws.center[1] + (np.arange(rows + 1) - rows / 2) * ws.cell_size
    for robot, kin in enumerate(kinematics):
        model = kin.model
        bx, by, yaw = ws.arm_base(robot)
        grip = ws.cube_size / 2 + FLANGE_GAP if model.grasps_from_top else 0.0
        place = ws.cube_size / 2 + DROP_GAP + grip     # tool height above the pedestal (= table) top
        # Corners on the border, and the middle of each edge (the nearest point to a base facing it).
        cx, cy = ws.center
        border = ({(x, y) for x in [*xs, cx] for y in (ys[0], ys[-1])}
                  | {(x, y) for x in (xs[0], xs[-1]) for y in [*ys, cy]})
        worst = 0.0
        for x, y in sorted(border):
            # The point in the arm's base frame (the URDF stands at the origin facing +x).
            dx, dy = x - bx, y - by
            lx, ly = dx * math.cos(yaw) + dy * math.sin(yaw), -dx * math.sin(yaw) + dy * math.cos(yaw)
            down = top_down_orientation(grasp_yaw(-yaw, math.atan2(ly, lx)))
            for height in (place, place + CLEARANCE_HEIGHT):
                _, error = kin.solve_ik([lx, ly, height], down, start=model.home)
                worst = max(worst, error)
                assert error <= REACH_IK_ERROR, (f'{rows}x{cols}: {model.name} misses ({x:.3f}, {y:.3f}) at '
                                                 f'{height:.3f} m by {error * 1000:.1f} mm')
        print(f'{rows}x{cols} {model.name}: worst IK error {worst * 1000:.2f} mm over {len(border)} points')

"""Where the grid lies on the simulated table and where the two arms stand (the Fig. 1 set-up).

The arms face each other across the table along one axis: the leader (a Franka Panda) on its
negative side, the follower (a KUKA iiwa) on its positive side, both at ``arm_distance`` from the
grid's centre. Their reach is the bridge's own arm model (``pybullet_bridge.core.arm.models``):
the ring of horizontal distances ``reach`` (measured for grasp and place poses and the travel
poses above them), the workable tool heights ``reach_height``, the azimuths ``REACH_AZIMUTH``
either side of the base's facing over which the reach was measured, and the pedestal.

A cell is within an arm's reach when, for the whole cell (a cube may lie anywhere in it, and
the bridge checks all four corners of a place region):

- its farthest corner is at most ``reach[1] - REACH_MARGIN`` from the base axis, and its nearest
  point at least ``reach[0] + REACH_MARGIN``;
- each corner lies within ``REACH_AZIMUTH`` of the arm's facing;
- the grasp and place tool heights of a cube on the table (the Panda holds a cube at its centre,
  the flange arms on its top face; the arms stand on pedestals as high as the table) are within
  ``reach_height``.

Placement from the grid (the default, :func:`place_arms`): cell sizes from ``MAX_CELL`` down to
``MIN_CELL`` in 5 mm steps (a given ``workspace.cell_size`` only), larger first; for each the axes
x then y (a given ``workspace.arm_axis`` only); on each axis the smallest distance, to the mm,
meeting every lower bound of both arms (nearest point, pedestal clear of the table, azimuth).
The first placement in which both arms reach every cell is taken; cubes are the largest (to
the mm, at most 2.5 cm) of which the bridge's pixel test finds 3 x 3 places in a cell with its
placement clearance (:func:`min_cell`), unless ``workspace.cube_size`` is given. The paper's 3 x 3 grid gets 0.10 m cells and the arms
along x at 0.565 m. When no placement works the task is refused with a
:class:`~.task_config.TaskConfigError` naming the cells each arm misses in the closest attempt.

A fixed placement (``workspace.arm_distance`` given) is the user's: cells out of one arm's
reach leave that arm's action set (:class:`~.rearrangement.ActionTable`), cells neither arm
reaches are refused.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

from collab_tools.core.fields import Fields
from pybullet_bridge.core.arm.models import ARM_MODELS, REACH_AZIMUTH, ArmModel
from pybullet_bridge.core.arm.requests import DROP_GAP, FLANGE_GAP

#: (scenario arm name, arm model) of the leader (robot 0) and the follower (robot 1).
ARMS: tuple[tuple[str, ArmModel], tuple[str, ArmModel]] = (
    ('leader_arm', ARM_MODELS['panda']), ('follower_arm', ARM_MODELS['kuka_iiwa']))
ROLES = ('leader', 'follower')
AXES = ('x', 'y')
#: Kept inside each arm's measured reach ring (m), against the IK tolerance.
REACH_MARGIN = 0.005
#: Gap kept around a placed cube by the bridge's pixel test (m).
PLACEMENT_CLEARANCE = 0.005
#: Cube spots per cell side (cubes start on a 3 x 3 pattern in their cell).
SPOTS_PER_SIDE = 3
#: Cell sizes tried by the placement, largest first (m): 0.100, 0.095, ..., 0.060.
MAX_CELL, MIN_CELL, CELL_STEP = 0.100, 0.060, 0.005
#: The largest cube edge chosen for a cell (the paper-like 2.5 cm cubes).
MAX_CUBE = 0.025
_EPS = 1e-9


@dataclass(frozen=True)
class Workspace:
    """Where the cell grid lies on the simulated table (world frame, metres) and where the arms stand."""

    center: tuple[float, float]
    cell_size: float
    table_height: float          # z of the table top
    cube_size: float             # edge of the cubes (their top faces are what the camera sees)
    arm_axis: str = 'x'          # the arms face each other along this axis (leader on its - side)
    arm_distance: float = 0.565  # m from the grid's centre to each arm's base axis
    placed: bool = True          # True: placed from the grid; False: the task fixed arm_distance
    #: per robot (leader, follower): per cell, is it within the arm's reach (empty: not computed)
    reach: tuple[tuple[bool, ...], ...] = ()

    def cell_region(self, rows: int, cols: int, cell: int) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) of a cell; row 0 is at +y (top of the camera image)."""
        row, col = divmod(cell, cols)
        x0 = self.center[0] - cols * self.cell_size / 2 + col * self.cell_size
        y1 = self.center[1] + rows * self.cell_size / 2 - row * self.cell_size
        return x0, y1 - self.cell_size, x0 + self.cell_size, y1

    def cell_of_point(self, rows: int, cols: int, x: float, y: float) -> int | None:
        """Cell containing the world point, or None outside the grid."""
        col = math.floor((x - (self.center[0] - cols * self.cell_size / 2)) / self.cell_size)
        row = math.floor(((self.center[1] + rows * self.cell_size / 2) - y) / self.cell_size)
        if 0 <= row < rows and 0 <= col < cols:
            return row * cols + col
        return None

    def arm_base(self, robot: int) -> tuple[float, float, float]:
        """(x, y, yaw) of robot 0's (leader) or robot 1's (follower) base, facing the grid."""
        return arm_base(self.center, self.arm_axis, self.arm_distance, robot)

    def reachable(self, robot: int, cell: int) -> bool:
        return not self.reach or self.reach[robot][cell]


def arm_base(center: tuple[float, float], axis: str, distance: float, robot: int) -> tuple[float, float, float]:
    sign = -1.0 if robot == 0 else 1.0
    if axis == 'x':
        return center[0] + sign * distance, center[1], 0.0 if robot == 0 else math.pi
    return center[0], center[1] + sign * distance, math.pi / 2 if robot == 0 else -math.pi / 2


def _wrap(angle: float) -> float:
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def _ceil_mm(value: float) -> float:
    return math.ceil(round(value * 1000.0, 6)) / 1000.0


def heights_problem(model: ArmModel, cube_size: float) -> str | None:
    """Why the arm cannot grasp or place a cube of this edge on a table as high as its pedestal."""
    grip = cube_size / 2.0 + FLANGE_GAP if model.grasps_from_top else 0.0
    low, high = model.reach_height
    for what, height in (('grasp', cube_size / 2.0 + grip), ('place', cube_size / 2.0 + DROP_GAP + grip)):
        if not low - _EPS <= height <= high + _EPS:
            return (f'the {model.name} {what} pose of a {cube_size} m cube is {height:+.3f} m above its base '
                    f'(workable {low:+.2f}..{high:+.2f} m)')
    return None


def cell_in_reach(model: ArmModel, base: tuple[float, float, float],
                  region: tuple[float, float, float, float]) -> bool:
    """The whole cell ``region`` is within the arm's reach ring and measured azimuths (see module doc)."""
    bx, by, yaw = base
    xmin, ymin, xmax, ymax = region
    corners = ((xmin, ymin), (xmin, ymax), (xmax, ymin), (xmax, ymax))
    farthest = max(math.hypot(x - bx, y - by) for x, y in corners)
    nearest = math.hypot(bx - min(max(bx, xmin), xmax), by - min(max(by, ymin), ymax))
    azimuth = max(abs(_wrap(math.atan2(y - by, x - bx) - yaw)) for x, y in corners)
    low, high = model.reach
    return (nearest >= low + REACH_MARGIN - _EPS and farthest <= high - REACH_MARGIN + _EPS
            and azimuth <= REACH_AZIMUTH + _EPS)


def _extent(rows: int, cols: int, cell: float, axis: str) -> tuple[float, float]:
    """(half extent along the arms' axis, half extent across it) of the grid."""
    width, depth = cols * cell, rows * cell
    return (width / 2, depth / 2) if axis == 'x' else (depth / 2, width / 2)


def nearest_distance(rows: int, cols: int, cell: float, axis: str) -> float:
    """The smallest distance (to the mm) meeting both arms' lower bounds: reach, pedestal, azimuth."""
    along, across = _extent(rows, cols, cell, axis)
    bound = max(max(model.reach[0] + REACH_MARGIN, model.pedestal_radius + 0.001,
                    across / math.tan(REACH_AZIMUTH)) for _, model in ARMS)
    return _ceil_mm(along + bound)


def pedestal_on_table(rows: int, cols: int, cell: float, axis: str, distance: float) -> bool:
    along, _ = _extent(rows, cols, cell, axis)
    return any(distance - model.pedestal_radius < along + _EPS for _, model in ARMS)


def reach_of(rows: int, cols: int, workspace: Workspace) -> tuple[tuple[bool, ...], ...]:
    """Per robot (leader, follower), per cell: within the arm's reach."""
    return tuple(tuple(cell_in_reach(model, workspace.arm_base(robot), workspace.cell_region(rows, cols, cell))
                       for cell in range(rows * cols))
                 for robot, (_, model) in enumerate(ARMS))


def describe_reach(rows: int, cols: int, workspace: Workspace) -> str:
    """Which cells each arm misses: "the follower (kuka_iiwa, reach 0.41..0.76 m) cannot reach cells (0,0), ..."."""
    parts = []
    for robot, (_, model) in enumerate(ARMS):
        missed = [f'({c // cols},{c % cols})' for c in range(rows * cols) if not workspace.reach[robot][c]]
        if missed:
            parts.append(f'the {ROLES[robot]} ({model.name}, reach {model.reach[0]:.2f}..{model.reach[1]:.2f} m) '
                         f"cannot reach cells {', '.join(missed)}")
    return '; '.join(parts)


def min_cell(cube: float) -> float:
    """The smallest cell in which the bridge's pixel test finds 3 x 3 places for cubes of this edge
    (each place is the cube plus the clearance on both sides, inside the cell)."""
    return SPOTS_PER_SIDE * cube + 4 * PLACEMENT_CLEARANCE


def default_cube(cell: float) -> float:
    """The largest cube (to the mm, at most MAX_CUBE) a cell holds 3 x 3 of (:func:`min_cell`)."""
    return min(MAX_CUBE, math.floor(round((cell - 4 * PLACEMENT_CLEARANCE) / SPOTS_PER_SIDE * 1000, 6)) / 1000.0)


def place_arms(rows: int, cols: int, base: Workspace, *, cell_size: float | None = None,
               cube_size: float | None = None, axis: str | None = None,
               fail: Callable[[str], Exception] = ValueError) -> Workspace:
    """The placement of the module doc, or ``fail('<message>')`` naming the cells the arms miss."""
    sizes = [cell_size] if cell_size is not None else \
        [round(MAX_CELL - i * CELL_STEP, 3) for i in range(int(round((MAX_CELL - MIN_CELL) / CELL_STEP)) + 1)]
    if cube_size is not None and cell_size is None:  # given cubes: 3 x 3 spots with clearance must fit
        sizes = [s for s in sizes if s + _EPS >= min_cell(cube_size)]
    best = None
    for size in sizes:
        for arm_axis in ([axis] if axis else AXES):
            trial = Workspace(base.center, size, base.table_height,
                              cube_size if cube_size is not None else default_cube(size), arm_axis,
                              nearest_distance(rows, cols, size, arm_axis), placed=True)
            trial = _with_reach(rows, cols, trial)
            missed = sum(not r for per_arm in trial.reach for r in per_arm)
            if missed == 0:
                return trial
            if best is None or missed < best[0]:
                best = (missed, trial)
    trial = best[1]
    tried = (f'{sizes[0]:.3f} m cells (workspace.cell_size)' if cell_size is not None
             else f'cells of {sizes[-1]:.3f}..{sizes[0]:.3f} m')
    along = f'along {axis} (workspace.arm_axis)' if axis else 'along x or y'
    raise fail(f'no placement of the two arms reaches every cell of the {rows}x{cols} grid ({tried}, arms '
               f'{along}); closest: {trial.cell_size:.3f} m cells, arms along {trial.arm_axis} at '
               f'{trial.arm_distance:.3f} m from the centre, where {describe_reach(rows, cols, trial)}')


def _with_reach(rows: int, cols: int, workspace: Workspace) -> Workspace:
    return Workspace(workspace.center, workspace.cell_size, workspace.table_height, workspace.cube_size,
                     workspace.arm_axis, workspace.arm_distance, workspace.placed, reach_of(rows, cols, workspace))


def parse_workspace(value, path: str, rows: int, cols: int, error: type[Exception],
                    grid_path: str = 'grid') -> Workspace:
    """The ``workspace`` section, placed (or its fixed placement checked) for a rows x cols grid.

    A grid no placement serves is refused as ``<grid_path>: no placement ...``."""
    ws = Fields(value if value is not None else {}, path, error=error,
                allowed=('center', 'cell_size', 'table_height', 'cube_size', 'arm_axis', 'arm_distance'))
    center = tuple(ws.vector('center', 2, (0.0, 0.0)))
    table_height = ws.number('table_height', 0.40, gt=0.0)
    cell_size = ws.number('cell_size', None, gt=0.0)
    cube_size = ws.number('cube_size', None, gt=0.0)
    axis = ws.choice('arm_axis', AXES, None)
    distance = ws.number('arm_distance', None, gt=0.0, le=0.9)
    if cell_size is not None and cube_size is not None and cube_size * SPOTS_PER_SIDE > cell_size:
        raise ws.fail('cube_size', f'three cubes must fit along a cell '
                                   f'(cube_size {cube_size} m, cell_size {cell_size} m)')
    if cube_size is not None and cell_size is None and min_cell(cube_size) > MAX_CELL + _EPS:
        raise ws.fail('cube_size', f'{cube_size} m cubes need cells of at least {min_cell(cube_size):.3f} m '
                                   f'(3 x 3 places with {PLACEMENT_CLEARANCE} m clearance), more than the '
                                   f'{MAX_CELL} m the placement tries; give workspace.cell_size')
    cell = cell_size if cell_size is not None else MAX_CELL
    cube = cube_size if cube_size is not None else default_cube(cell)
    for _, model in ARMS:
        problem = heights_problem(model, cube)
        if problem:
            raise ws.fail('cube_size', problem)
    base = Workspace(center, cell, table_height, cube)
    if distance is None:
        return place_arms(rows, cols, base, cell_size=cell_size, cube_size=cube_size, axis=axis,
                          fail=lambda message: error(f'{grid_path}: {message}'))
    fixed = Workspace(center, cell, table_height, cube, axis or 'x', distance, placed=False)
    if pedestal_on_table(rows, cols, cell, fixed.arm_axis, distance):
        along, _ = _extent(rows, cols, cell, fixed.arm_axis)
        raise ws.fail('arm_distance', f"an arm's pedestal would stand on the table ({distance} m from the "
                                      f'centre; the grid reaches {along:.3f} m along {fixed.arm_axis})')
    fixed = _with_reach(rows, cols, fixed)
    neither = [f'({c // cols},{c % cols})' for c in range(rows * cols) if not (fixed.reach[0][c] or fixed.reach[1][c])]
    if neither:
        raise ws.fail('arm_distance', f"neither arm reaches cells {', '.join(neither)} (arms along "
                                      f'{fixed.arm_axis} at {distance} m; {describe_reach(rows, cols, fixed)})')
    return fixed

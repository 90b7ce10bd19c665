"""Task configuration of the rearrangement game and its initial configurations (cases).

Everything the paper leaves as a parameter lives in a YAML file (config/sgcm/task.yaml
documents every field and its default); this module reads and validates it. A
mistake raises :class:`TaskConfigError` whose message starts with the field path,
e.g. ``game.failure_probability.leader: must be <= 1.0 (got 1.5)``.

Cells are numbered row-major from the top-left cell (row 0 is the top row, the
side of the table farthest from the camera's image bottom); colours are numbered in
file order.
"""
from __future__ import annotations

import copy
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import yaml
from collab_tools.core.errors import ConfigurationError
from collab_tools.core.fields import Fields, check_color, check_int, join_path, read_yaml_file, require_list, \
    require_mapping
from collab_tools.core.settings import echo

from .workspace_layout import Workspace, parse_workspace


class TaskConfigError(ConfigurationError):
    """A task or case file the planner cannot use; the message names the field."""


DISTANCES = ('chebyshev', 'manhattan')
#: The largest prediction horizon T a task may ask for (game.horizon; the leader's horizon parameter).
MAX_HORIZON = 6


@dataclass(frozen=True)
class RobotModel:
    """What one arm can do in the abstract game."""

    directions: int              # 4 (horizontal/vertical) or 8 (also diagonal)
    move_cost: float             # cost of a horizontal/vertical move from an uncluttered cell
    diagonal_cost: float         # cost of a diagonal move from an uncluttered cell
    failure_probability: float   # p_fail: the move turns into the empty action


@dataclass(frozen=True)
class ClutterRule:
    """The cost of taking an object from a cell doubles as the cell gets crowded.

    multiplier(n) = factor ** floor(n / threshold) for a source cell holding n objects
    (the moved one included): with threshold 3 and factor 2, cells with 1-2 objects
    cost the base price, 3-5 twice, 6-8 four times.
    """

    threshold: int
    factor: float

    def multiplier(self, objects_in_cell: np.ndarray | int) -> np.ndarray | float:
        return self.factor ** (np.asarray(objects_in_cell) // self.threshold)


@dataclass(frozen=True)
class RewardModel:
    """Reward of a state, proportional to its closeness to the goal.

    r(s) = scale * sum over objects of (d_max - d(cell, goal cell of its colour))
           + goal_bonus if every object is in its goal cell,
    with d the grid distance named by ``distance`` and d_max the largest distance on
    the grid, so every object contributes a value in [0, scale * d_max].
    """

    scale: float
    distance: str
    goal_bonus: float


@dataclass(frozen=True)
class UtilityWeights:
    """u^i(s, a^A, a^B) = r(s) - own * c^i - other * c^(-i) for i in {leader, follower}.

    The default (all ones) gives both robots the team utility, the paper's first way of
    making the leader's guidance good for the follower (Section III-A).
    """

    leader_own: float = 1.0
    leader_other: float = 1.0
    follower_own: float = 1.0
    follower_other: float = 1.0


@dataclass(frozen=True)
class TaskConfig:
    rows: int
    cols: int
    cell_capacity: int
    colours: tuple[str, ...]
    colour_rgb: tuple[tuple[float, float, float], ...]
    goals: tuple[int, ...]                 # goal cell per colour
    leader: RobotModel
    follower: RobotModel
    clutter: ClutterRule
    reward: RewardModel
    utility: UtilityWeights
    horizon: int                           # T
    discount: float                        # gamma
    round_limit: int
    charge_failed_actions: bool
    workspace: Workspace                   # cell size, cubes, arm placement and reach (workspace_layout)
    source: Path | None = None
    data: dict | None = field(default=None, repr=False, compare=False)   # the parsed mapping (cases merge into it)

    @property
    def cells(self) -> int:
        return self.rows * self.cols

    def cell_name(self, cell: int) -> str:
        row, col = divmod(cell, self.cols)
        return f'({row},{col})'

    def colour_index(self, name: str) -> int:
        try:
            return self.colours.index(name)
        except ValueError:
            raise TaskConfigError(f"unknown colour '{name}' (known: {', '.join(self.colours)})") from None


@dataclass(frozen=True)
class Case:
    """An initial configuration: object counts per cell and colour, on its own task.

    ``task`` is the task the case is played on: the file's task, or that task with the case's
    own grid and goals (see :func:`parse_case`); None for a case built by hand (play it on the
    task it was built for; :func:`task_of`).
    """

    name: str
    counts: np.ndarray = field(repr=False)   # (cells, colours) int
    task: TaskConfig | None = field(default=None, repr=False, compare=False)

    @property
    def objects(self) -> int:
        return int(self.counts.sum())


# --- loading -------------------------------------------------------------------------

def _read_yaml(path: str | Path, what: str) -> Any:
    return read_yaml_file(path, f'{what} file', error=TaskConfigError)


def load_task(path: str | Path, overrides: dict | None = None) -> TaskConfig:
    """Read config/sgcm/task.yaml-style files; ``overrides`` is merged into ``game`` (e.g. horizon)."""
    data = _read_yaml(path, 'task')
    if overrides:
        data = dict(data)
        data['game'] = {**(data.get('game') or {}), **overrides}
    try:
        return parse_task(data, source=Path(path).resolve())
    except TaskConfigError as err:
        raise TaskConfigError(f'{err} (in {path})') from None


def _cell(value: Any, path: str, rows: int, cols: int) -> int:
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        raise TaskConfigError(f'{path}: must be a cell [row, col] (got {echo(value)})')
    row = check_int(value[0], join_path(path, 0), ge=0, error=TaskConfigError)
    col = check_int(value[1], join_path(path, 1), ge=0, error=TaskConfigError)
    if row >= rows or col >= cols:
        raise TaskConfigError(f'{path}: cell [{row}, {col}] is outside the {rows}x{cols} grid '
                              f'(rows 0..{rows - 1}, cols 0..{cols - 1})')
    return row * cols + col


def _robot(value: Any, path: str, default_directions: int) -> RobotModel:
    f = Fields(value if value is not None else {}, path, error=TaskConfigError,
               allowed=('directions', 'move_cost', 'diagonal_cost', 'failure_probability'))
    directions = f.integer('directions', default_directions)
    if directions not in (4, 8):
        raise TaskConfigError(f'{f.path_of("directions")}: must be 4 or 8 (got {directions})')
    move_cost = f.number('move_cost', 1.0, ge=0.0)
    return RobotModel(directions=directions, move_cost=move_cost,
                      diagonal_cost=f.number('diagonal_cost', move_cost, ge=0.0),
                      failure_probability=f.number('failure_probability', 0.1, ge=0.0, le=1.0))


def parse_task(data: Any, source: Path | None = None) -> TaskConfig:
    top = Fields(data, '', allowed=('grid', 'colours', 'robots', 'cost', 'reward', 'utility', 'game',
                                    'workspace'), error=TaskConfigError)
    grid = Fields(top.raw('grid', {}), 'grid', allowed=('rows', 'cols', 'cell_capacity'), error=TaskConfigError)
    rows = grid.integer('rows', 3, ge=1, le=10)
    cols = grid.integer('cols', 3, ge=1, le=10)
    if rows * cols < 2:
        raise TaskConfigError('grid: needs at least two cells')
    capacity = grid.integer('cell_capacity', 6, ge=1, le=50)

    colour_items = require_mapping(top.raw('colours'), 'colours', error=TaskConfigError)
    if not colour_items:
        raise TaskConfigError('colours: at least one colour is required')
    names, rgbs, goals = [], [], []
    for name, spec in colour_items.items():
        path = join_path('colours', str(name))
        if not isinstance(name, str) or not name.isidentifier():
            raise TaskConfigError(f'{path}: colour names must be identifiers (got {echo(name)})')
        f = Fields(spec, path, allowed=('goal', 'rgb'), error=TaskConfigError)
        names.append(name)
        goals.append(_cell(f.raw('goal'), f.path_of('goal'), rows, cols))
        rgbs.append(check_color(f.raw('rgb'), f.path_of('rgb'), error=TaskConfigError))

    robots = Fields(top.raw('robots', {}), 'robots', allowed=('leader', 'follower'), error=TaskConfigError)
    leader = _robot(robots.raw('leader', None), 'robots.leader', 8)
    follower = _robot(robots.raw('follower', None), 'robots.follower', 4)

    cost = Fields(top.raw('cost', {}), 'cost', allowed=('clutter_threshold', 'clutter_factor',
                                                        'charge_failed_actions'), error=TaskConfigError)
    clutter = ClutterRule(threshold=cost.integer('clutter_threshold', 3, ge=1),
                          factor=cost.number('clutter_factor', 2.0, ge=1.0))
    charge_failed = cost.raw('charge_failed_actions', True)
    if not isinstance(charge_failed, bool):
        raise TaskConfigError(f'cost.charge_failed_actions: must be true or false (got {echo(charge_failed)})')

    reward = Fields(top.raw('reward', {}), 'reward', allowed=('scale', 'distance', 'goal_bonus'),
                    error=TaskConfigError)
    distance = reward.string('distance', 'chebyshev')
    if distance not in DISTANCES:
        raise TaskConfigError(f"reward.distance: must be one of {', '.join(DISTANCES)} (got '{distance}')")
    reward_model = RewardModel(scale=reward.number('scale', 1.0, gt=0.0), distance=distance,
                               goal_bonus=reward.number('goal_bonus', 0.0, ge=0.0))

    util = Fields(top.raw('utility', {}), 'utility', allowed=('leader', 'follower'), error=TaskConfigError)
    weights = {}
    for who in ('leader', 'follower'):
        f = Fields(util.raw(who, {}), util.path_of(who), allowed=('own_cost', 'other_cost'),
                   error=TaskConfigError)
        weights[f'{who}_own'] = f.number('own_cost', 1.0, ge=0.0)
        weights[f'{who}_other'] = f.number('other_cost', 1.0, ge=0.0)

    game = Fields(top.raw('game', {}), 'game', allowed=('horizon', 'discount', 'round_limit',
                                                        'failure_probability'), error=TaskConfigError)
    failure = game.raw('failure_probability', None)
    if failure is not None:
        # game.failure_probability overrides both robots' p_fail (experiments sweep it).
        fp = Fields(failure, 'game.failure_probability', allowed=('leader', 'follower'),
                    error=TaskConfigError)
        leader = RobotModel(leader.directions, leader.move_cost, leader.diagonal_cost,
                            fp.number('leader', leader.failure_probability, ge=0.0, le=1.0))
        follower = RobotModel(follower.directions, follower.move_cost, follower.diagonal_cost,
                              fp.number('follower', follower.failure_probability, ge=0.0, le=1.0))

    workspace = parse_workspace(top.raw('workspace', None), 'workspace', rows, cols, TaskConfigError)

    return TaskConfig(
        rows=rows, cols=cols, cell_capacity=capacity, colours=tuple(names),
        colour_rgb=tuple(rgbs), goals=tuple(goals), leader=leader, follower=follower,
        clutter=clutter, reward=reward_model, utility=UtilityWeights(**weights),
        horizon=game.integer('horizon', 2, ge=1, le=MAX_HORIZON),
        discount=game.number('discount', 0.9, gt=0.0, le=1.0),
        round_limit=game.integer('round_limit', 20, ge=1),
        charge_failed_actions=charge_failed, workspace=workspace, source=source, data=copy.deepcopy(dict(data)))


def load_cases(path: str | Path, task: TaskConfig) -> list[Case]:
    """Read the initial configurations of a cases file and check them against ``task``."""
    data = _read_yaml(path, 'cases')
    try:
        return parse_cases(data, task)
    except TaskConfigError as err:
        raise TaskConfigError(f'{err} (in {path})') from None


def parse_cases(data: Any, task: TaskConfig) -> list[Case]:
    top = Fields(data, '', allowed=('cases',), error=TaskConfigError)
    items = require_list(top.raw('cases'), 'cases', error=TaskConfigError)
    if not items:
        raise TaskConfigError('cases: at least one case is required')
    cases, seen = [], set()
    for index, item in enumerate(items):
        case = parse_case(item, task, join_path('cases', index))
        if case.name in seen:
            raise TaskConfigError(f"{join_path('cases', index)}.name: duplicate case name '{case.name}'")
        seen.add(case.name)
        cases.append(case)
    return cases


def task_of(case: Case, task: TaskConfig) -> TaskConfig:
    """The task ``case`` is played on (its own grid and goals, else ``task``)."""
    return case.task if case.task is not None else task


def task_yaml(task: TaskConfig) -> str:
    """The task as a task file (a case's own task, for the nodes): colours keep their order."""
    return yaml.safe_dump(task.data, sort_keys=False)


def _or_empty(value: Any) -> Any:
    return {} if value is None else value


def case_task(item: Mapping[str, Any], task: TaskConfig, path: str) -> TaskConfig:
    """``task`` with the case's own ``grid`` (rows, cols, cell_capacity) and ``goals`` (colour: [row, col]).

    Both optional; a colour without a goal of its own keeps the task's, which must then lie on
    the case's grid. The merged task is placed like any task (workspace_layout): a grid the arms
    cannot serve is refused here, naming the case and the cells.
    """
    if item.get('grid') is None and item.get('goals') is None:
        return task
    base = task.data if task.data is not None else {}
    grid = Fields(_or_empty(item.get('grid')), join_path(path, 'grid'), allowed=('rows', 'cols', 'cell_capacity'),
                  error=TaskConfigError)
    rows = grid.integer('rows', task.rows, ge=1, le=10)
    cols = grid.integer('cols', task.cols, ge=1, le=10)
    if rows * cols < 2:
        raise TaskConfigError(f'{grid.path}: needs at least two cells')
    capacity = grid.integer('cell_capacity', task.cell_capacity, ge=1, le=50)
    goals_path = join_path(path, 'goals')
    goals = dict(require_mapping(_or_empty(item.get('goals')), goals_path, error=TaskConfigError))
    for colour, goal in goals.items():
        if colour not in task.colours:
            raise TaskConfigError(f"{join_path(goals_path, str(colour))}: unknown colour '{colour}' "
                                  f"(known: {', '.join(task.colours)})")
        _cell(goal, join_path(goals_path, colour), rows, cols)
    for colour, goal in zip(task.colours, task.goals):
        row, col = divmod(goal, task.cols)
        if colour not in goals and (row >= rows or col >= cols):
            raise TaskConfigError(f"{goals_path}: the task's goal of {colour} [{row}, {col}] is outside the case's "
                                  f'{rows}x{cols} grid; give {join_path(goals_path, colour)}')
    data = copy.deepcopy(dict(base))
    data['grid'] = {**(data.get('grid') or {}), 'rows': rows, 'cols': cols, 'cell_capacity': capacity}
    colours = data['colours']
    for colour, goal in zip(task.colours, task.goals):
        colours[colour] = {**colours[colour], 'goal': list(goals.get(colour, divmod(goal, task.cols)))}
    try:
        return parse_task(data, source=task.source)
    except TaskConfigError as err:   # only the placement is left to fail: name the case's grid
        raise TaskConfigError(f'{path}.{err}') from None


def parse_case(item: Any, task: TaskConfig, path: str = 'case') -> Case:
    """One case: ``{name, objects: {colour: [[row, col], ...]}}``, one cell entry per object,
    optionally with its own ``grid`` and ``goals`` (:func:`case_task`)."""
    f = Fields(item, path, allowed=('name', 'grid', 'goals', 'objects'), error=TaskConfigError)
    name = f.string('name')
    task = case_task(f.data, task, path)
    objects = require_mapping(f.raw('objects'), f.path_of('objects'), error=TaskConfigError)
    counts = np.zeros((task.cells, len(task.colours)), dtype=np.int64)
    for colour, cells in objects.items():
        cpath = join_path(f.path_of('objects'), str(colour))
        if colour not in task.colours:
            raise TaskConfigError(f"{cpath}: unknown colour '{colour}' "
                                  f"(known: {', '.join(task.colours)})")
        for i, cell in enumerate(require_list(cells, cpath, error=TaskConfigError)):
            counts[_cell(cell, join_path(cpath, i), task.rows, task.cols),
                   task.colours.index(colour)] += 1
    if counts.sum() == 0:
        raise TaskConfigError(f'{f.path_of("objects")}: the case has no objects')
    totals = counts.sum(axis=1)
    if totals.max() > task.cell_capacity:
        cell = int(totals.argmax())
        raise TaskConfigError(
            f'{f.path_of("objects")}: cell {task.cell_name(cell)} holds {int(totals[cell])} objects, '
            f'more than grid.cell_capacity = {task.cell_capacity}')
    goal_totals = np.zeros(task.cells, dtype=np.int64)
    for colour, goal in enumerate(task.goals):
        goal_totals[goal] += counts[:, colour].sum()
    if goal_totals.max() > task.cell_capacity:
        cell = int(goal_totals.argmax())
        raise TaskConfigError(
            f'{f.path_of("objects")}: the goal cell {task.cell_name(cell)} would have to hold '
            f'{int(goal_totals[cell])} objects, more than grid.cell_capacity = {task.cell_capacity}')
    _check_objects_can_reach_goals(task, counts, f.path_of('objects'))
    return Case(name=name, counts=counts, task=task)


def _check_objects_can_reach_goals(task: TaskConfig, counts: np.ndarray, path: str) -> None:
    """With a fixed arm placement some cells are out of one arm's reach: every object must still
    have a way to its goal cell through moves of either arm (moves between cells it reaches)."""
    ws = task.workspace
    if not ws.reach or all(all(per_arm) for per_arm in ws.reach):
        return
    steps = []
    for robot, model in enumerate((task.leader, task.follower)):
        offsets = [(-1, 0), (1, 0), (0, -1), (0, 1)] + ([(-1, -1), (-1, 1), (1, -1), (1, 1)]
                                                        if model.directions == 8 else [])
        steps.append((robot, offsets))
    for colour, goal in enumerate(task.goals):
        served, frontier = {goal}, [goal]
        while frontier:   # moves are reversible: the cells from which the goal can be reached
            cell = frontier.pop()
            row, col = divmod(cell, task.cols)
            for robot, offsets in steps:
                if not ws.reachable(robot, cell):
                    continue
                for dr, dc in offsets:
                    r, c = row + dr, col + dc
                    other = r * task.cols + c
                    if 0 <= r < task.rows and 0 <= c < task.cols and other not in served \
                            and ws.reachable(robot, other):
                        served.add(other)
                        frontier.append(other)
        stranded = [task.cell_name(c) for c in np.flatnonzero(counts[:, colour]) if int(c) not in served]
        if stranded:
            raise TaskConfigError(
                f'{join_path(path, task.colours[colour])}: no sequence of moves the arms can make brings the '
                f"object(s) in {', '.join(stranded)} to the goal {task.cell_name(goal)} (cells out of an arm's "
                'reach leave its moves; see workspace.arm_distance)')

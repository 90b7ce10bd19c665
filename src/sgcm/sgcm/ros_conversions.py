"""Conversions between sgcm_interfaces messages and the core's states and actions.

Every reader validates what it gets and raises ValueError naming the bad field, so the
nodes can log and drop a malformed message instead of crashing.
"""
from __future__ import annotations

import numpy as np
from bridge_interfaces.action import PickAndPlace
from sgcm_interfaces.msg import GridState, Move

from .core.perception import StateEstimate
from .core.rearrangement import EMPTY, Move as CoreMove, RearrangementModel
from .core.task_config import TaskConfig

# The SGCM channels, under the team namespace (names.RobotNode.team): leader -> follower, and
# the follower's "round over".
GUIDANCE = 'sgcm/guidance'
FOLLOWER_REPORT = 'sgcm/follower_report'


def grid_state_msg(task: TaskConfig, counts: np.ndarray) -> GridState:
    counts = np.asarray(counts).reshape(-1)
    return GridState(rows=task.rows, cols=task.cols, colours=list(task.colours),
                     counts=[int(c) for c in counts])


def counts_from_msg(task: TaskConfig, msg: GridState) -> np.ndarray:
    if (msg.rows, msg.cols) != (task.rows, task.cols):
        raise ValueError(f'state: grid {msg.rows}x{msg.cols} does not match the task grid {task.rows}x{task.cols}')
    if list(msg.colours) != list(task.colours):
        raise ValueError(f'state.colours: {list(msg.colours)} do not match the task colours {list(task.colours)}')
    expected = task.cells * len(task.colours)
    if len(msg.counts) != expected:
        raise ValueError(f'state.counts: expected {expected} entries (cells x colours), got {len(msg.counts)}')
    return np.array(msg.counts, dtype=np.int64)


def move_msg(model: RearrangementModel, robot: int, action: int) -> Move:
    if action == EMPTY:
        return Move(empty=True)
    move = model.actions[robot].move(action)
    return Move(empty=False, source_cell=move.source, target_cell=move.target,
                colour=model.task.colours[move.colour])


def action_from_msg(model: RearrangementModel, robot: int, msg: Move, field: str = 'move') -> int:
    """Action index of a Move message for ``robot``; ValueError names what is wrong."""
    if msg.empty:
        return EMPTY
    task = model.task
    if msg.colour not in task.colours:
        raise ValueError(f"{field}.colour: unknown colour '{msg.colour}' (known: {', '.join(task.colours)})")
    for name in ('source_cell', 'target_cell'):
        if getattr(msg, name) >= task.cells:
            raise ValueError(f'{field}.{name}: cell {getattr(msg, name)} is outside the grid '
                             f'(0..{task.cells - 1})')
    try:
        return model.actions[robot].index_of(CoreMove(msg.source_cell, msg.target_cell,
                                                      task.colours.index(msg.colour)))
    except ValueError as error:
        raise ValueError(f'{field}: {error}') from None


def pick_and_place_goal(model: RearrangementModel, robot: int, action: int,
                        estimate: StateEstimate) -> PickAndPlace.Goal:
    """Goal for the arm: a seen cube of the move's colour from its source into its target cell.

    ValueError when the camera shows no such cube (the move then has no effect).
    """
    task = model.task
    move = model.actions[robot].move(action)
    candidates = estimate.objects_in(move.source, move.colour)
    if not candidates:
        raise ValueError(f'no {task.colours[move.colour]} cube seen in cell {task.cell_name(move.source)}')
    return PickAndPlace.Goal(object_name=candidates[0].name,
                             place_region=list(task.workspace.cell_region(task.rows, task.cols, move.target)))

"""SGCM as markers: the grid on the table, the leader's estimate of the cube counts, the moves.

Built from the leader's ``Guidance`` (and the follower's ``FollowerReport``) with the task's
workspace (where the grid lies, :mod:`.workspace_layout`) and colours; plain
:class:`~collab_tools.core.marker_specs.MarkerSpec` lists in the world frame, published by the
visualiser node on ``markers/sgcm``. Messages are read by attribute only (unit tests use stand-ins).

Marker namespaces: ``grid`` (cell borders), ``goals`` (each colour's goal cell, translucent),
``estimate`` (one small cube per object the leader saw, floating above its cell) and ``counts``
(text per cell), ``recommended`` (the follower move the leader recommends), ``leader_move`` and
``leader_policy`` (her committed policy, alpha = probability), ``status`` (round, strategy, the
follower's answer).
"""
from __future__ import annotations

from pathlib import Path

from collab_tools.core.marker_specs import MarkerInput, MarkerSpec, rgba
from collab_tools.core.settings import Setting

from .task_config import TaskConfig, load_task

#: Heights above the table top (m) of the marker layers: estimate, leader arrows, follower arrows, texts.
ESTIMATE_Z, LEADER_Z, FOLLOWER_Z, TEXT_Z = 0.12, 0.18, 0.24, 0.32


def _centre(task: TaskConfig, cell: int) -> tuple[float, float]:
    x0, y0, x1, y1 = task.workspace.cell_region(task.rows, task.cols, cell)
    return (x0 + x1) / 2, (y0 + y1) / 2


def _check_state(task: TaskConfig, state) -> list[int]:
    rows, cols, colours = int(state.rows), int(state.cols), list(state.colours)
    if (rows, cols) != (task.rows, task.cols):
        raise ValueError(f'guidance.state: grid {rows} x {cols}, the task has {task.rows} x {task.cols}')
    counts = [int(c) for c in state.counts]
    if len(counts) != rows * cols * len(colours):
        raise ValueError(f'guidance.state.counts: {len(counts)} entries, expected rows * cols * colours = '
                         f'{rows * cols * len(colours)}')
    return counts


def _colour(task: TaskConfig, name: str, alpha: float = 1.0):
    if name in task.colours:
        return rgba(task.colour_rgb[task.colours.index(name)], alpha)
    return (0.5, 0.5, 0.5, alpha)


def grid_markers(task: TaskConfig, frame: str) -> list[MarkerSpec]:
    """Cell borders on the table top and each colour's goal cell."""
    ws, z = task.workspace, task.workspace.table_height + 0.002
    pairs = []
    for cell in range(task.cells):
        x0, y0, x1, y1 = ws.cell_region(task.rows, task.cols, cell)
        pairs += [((x0, y0, z), (x1, y0, z)), ((x1, y0, z), (x1, y1, z)),
                  ((x1, y1, z), (x0, y1, z)), ((x0, y1, z), (x0, y0, z))]
    points = tuple(p for pair in pairs for p in pair)
    specs = [MarkerSpec('grid', 0, 'line_list', frame, scale=(0.004, 0, 0), color=(0.2, 0.2, 0.2, 1.0), points=points)]
    for index, (name, goal) in enumerate(zip(task.colours, task.goals)):
        x, y = _centre(task, goal)
        specs.append(MarkerSpec('goals', index, 'cube', frame, position=(x, y, z + 0.001),
                                scale=(ws.cell_size * 0.9, ws.cell_size * 0.9, 0.002), color=_colour(task, name, 0.3)))
    return specs


def estimate_markers(task: TaskConfig, state, frame: str) -> list[MarkerSpec]:
    """The leader's estimate: a small cube per object above its cell, and the counts as text."""
    counts = _check_state(task, state)
    colours, ws = list(state.colours), task.workspace
    size, z = ws.cell_size / 4, ws.table_height + ESTIMATE_Z
    points, colors, specs = [], [], []
    for cell in range(task.cells):
        cx, cy = _centre(task, cell)
        slot, words = 0, []
        for k, name in enumerate(colours):
            n = counts[cell * len(colours) + k]
            if n > 0:
                words.append(f'{n} {name}')
            for _ in range(n):
                row, col = divmod(slot % 9, 3)  # a cell shows up to 3 x 3, then stacks
                points.append((cx + (col - 1) * size * 1.1, cy + (1 - row) * size * 1.1, z + (slot // 9) * size))
                colors.append(_colour(task, name))
                slot += 1
        if words:
            specs.append(MarkerSpec('counts', cell, 'text', frame, position=(cx, cy, ws.table_height + TEXT_Z),
                                    scale=(0, 0, 0.02), text=', '.join(words)))
    if points:
        specs.insert(0, MarkerSpec('estimate', 0, 'cube_list', frame, scale=(size, size, size), points=tuple(points),
                                   colors=tuple(colors)))
    return specs


def move_marker(task: TaskConfig, move, ns: str, marker_id: int, frame: str, height: float,
                alpha: float = 1.0) -> MarkerSpec | None:
    """An arrow from the move's source cell to its target cell, in the cube's colour (None: empty move)."""
    if bool(move.empty):
        return None
    source, target = int(move.source_cell), int(move.target_cell)
    for field, cell in (('source_cell', source), ('target_cell', target)):
        if not 0 <= cell < task.cells:
            raise ValueError(f'{ns}.{field}: {cell} is not a cell of the {task.rows} x {task.cols} grid')
    (x0, y0), (x1, y1) = _centre(task, source), _centre(task, target)
    z = task.workspace.table_height + height
    return MarkerSpec(ns, marker_id, 'arrow', frame, scale=(0.012, 0.03, 0.03),
                      color=_colour(task, str(move.colour), alpha), points=((x0, y0, z), (x1, y1, z)))


def _describe(task: TaskConfig, move) -> str:
    if bool(move.empty):
        return 'no move'
    return f'{move.colour} {task.cell_name(int(move.source_cell))} -> {task.cell_name(int(move.target_cell))}'


def guidance_markers(task: TaskConfig, guidance, report=None, frame: str = 'world') -> list[MarkerSpec]:
    """Everything one round shows: the estimate, the leader's move and policy, the recommendation."""
    specs = estimate_markers(task, guidance.state, frame)
    probabilities = list(guidance.leader_policy_probabilities)
    for index, move in enumerate(guidance.leader_policy_moves):
        p = probabilities[index] if index < len(probabilities) else 1.0
        marker = move_marker(task, move, 'leader_policy', index, frame, LEADER_Z - 0.02, alpha=max(0.15, min(1.0, p)))
        if marker is not None:
            specs.append(marker)
    for ns, move, height in (('leader_move', guidance.leader_move, LEADER_Z),
                             ('recommended', guidance.recommended_follower_move, FOLLOWER_Z)):
        marker = move_marker(task, move, ns, 0, frame, height)
        if marker is not None:
            specs.append(marker)
    lines = [f'round {int(guidance.round)} ({guidance.strategy}, T={int(guidance.horizon)})',
             f'leader: {_describe(task, guidance.leader_move)}',
             f'follower, recommended: {_describe(task, guidance.recommended_follower_move)}']
    if report is not None and int(report.round) == int(guidance.round):
        lines.append(f'follower ({report.behaviour}): {_describe(task, report.move)}'
                     + (' (deviated)' if bool(report.deviated) else ''))
    if bool(guidance.task_complete) or guidance.status:
        lines.append(str(guidance.status) or 'task complete')
    cx, cy = task.workspace.center
    top = task.workspace.cell_region(task.rows, task.cols, 0)[3]
    specs.append(MarkerSpec('status', 0, 'text', frame, position=(cx, top + 0.08, task.workspace.table_height + TEXT_Z),
                            scale=(0, 0, 0.025), text='\n'.join(lines)))
    return specs


class SgcmMarkers:
    """The visualiser's SGCM source (collab_tools.core.marker_specs): guidance and reports in, markers out."""

    SETTINGS = (Setting('task_file', '', "SGCM task YAML the grid is drawn from; '' = the task_file parameter "
                        'of the node publishing the guidance (the leader)'),)
    INPUTS = (MarkerInput('sgcm/guidance', 'sgcm_interfaces/msg/Guidance', 'reliable', 'on_guidance',
                          publisher_parameter='task_file'),
              MarkerInput('sgcm/follower_report', 'sgcm_interfaces/msg/FollowerReport', 'reliable', 'on_report'))
    time_dependent = False

    def __init__(self, world_frame: str = 'world', task_file: str = ''):
        self.frame = world_frame
        self.task: TaskConfig | None = None
        self.guidance = None
        self.report = None
        if task_file:
            self.set_parameter('task_file', task_file)

    def wants_parameter(self, name: str) -> bool:
        return name == 'task_file' and self.task is None

    def set_parameter(self, name: str, value: str) -> None:
        if name == 'task_file':
            self.task = load_task(Path(value))

    def on_guidance(self, msg, topic: str = '') -> None:
        if self.task is not None:
            _check_state(self.task, msg.state)  # a malformed estimate is refused here, not drawn
        self.guidance = msg

    def on_report(self, msg, topic: str = '') -> None:
        self.report = msg

    def markers(self, now: float = 0.0) -> list[MarkerSpec] | None:
        if self.task is None:
            return None
        specs = grid_markers(self.task, self.frame)
        if self.guidance is not None:
            specs += guidance_markers(self.task, self.guidance, self.report, self.frame)
        return specs

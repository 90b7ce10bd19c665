"""The parameters of the leader_planner and follower_executor nodes, as plain data.

Each node declares its schema (``NodeParameters.declare_schema``) and builds its settings from the
start values (:meth:`LeaderSettings.from_values`, :meth:`FollowerExecutorSettings.from_values`),
which also read the task file. Both nodes also have ``robot`` and ``team_namespace``
(declared by ``collab_tools.names.RobotNode``). Bad values raise
:class:`~collab_tools.core.errors.ConfigurationError` naming the parameter (exit code 2).
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from collab_tools.core.errors import ConfigurationError
from collab_tools.core.settings import Setting, SettingsSchema

from .follower_behaviour import BEHAVIOURS, FollowerSettings
from .fse_compiled import PLANNER_PATHS
from .leader_round import STRATEGIES
from .perception_check import FAULT_AFTER
from .sessions import MAX_ROUND_JUMP
from .stage_game import SOLVERS
from .task_config import MAX_HORIZON, TaskConfig, TaskConfigError, load_task

#: The camera's image transports, as collab_tools.top_camera.TRANSPORTS names them (a unit test
#: keeps the two equal; that module subscribes, so the core cannot import it).
IMAGE_TRANSPORTS = ('raw', 'compressed')


def _camera_problem(value: str) -> str | None:
    return None if value.strip('/') else "must name the camera's namespace (got '')"


def _node_name_problem(value: str) -> str | None:
    tokens = value.split('/')
    if value and all(t and (t[0].isalpha() or t[0] == '_') and t.replace('_', '').isalnum() for t in tokens):
        return None
    return f"must be a node's name under the team namespace, like leader_arm/leader_planner (got {value[:80]!r})"


#: Settings both nodes have, in the order they are declared.
TASK_FILE = Setting('task_file', '', 'task YAML (config/sgcm/task.yaml)', required=True)
CAMERA = Setting('camera', 'top_camera', 'camera namespace, under the team namespace', check=_camera_problem)
IMAGE_TRANSPORT = Setting(
    'image_transport', 'raw', "the camera's image_transport: raw (image_raw, labels) or compressed "
    '(image_raw/compressed JPEG, labels/compressed PNG: for a node on another host)', choices=IMAGE_TRANSPORTS)
PERCEPTION_FAULT_AFTER = Setting(
    'perception_fault_after', FAULT_AFTER, 'sim seconds of camera frames rejected in a row (a cube of the '
    "camera's legend not seen in the grid: sgcm.core.perception_check) before a perception fault: the leader "
    'ends the task unfinished, the follower logs it and keeps looking (applied at once)', low=0.0, low_open=True,
    dynamic=True)

LEADER_SETTINGS = SettingsSchema(
    TASK_FILE,
    Setting('horizon', 0, 'T, the prediction horizon; 0 = the task file game.horizon (applied from the next '
            'round)', low=0, high=MAX_HORIZON, dynamic=True),
    Setting('solver', 'fast', 'stage-game solver (general-sum games; a cooperative game, U^A = U^B, is settled '
            'by its maximal entry on the kernel path)', choices=tuple(SOLVERS)),
    Setting('planner', 'kernel', 'FSE path: kernel (compiled, sgcm.core.fse_compiled) | reference (numpy and the '
            'stage-game solver per state, sgcm.core.fse; for cross-checks)', choices=PLANNER_PATHS),
    Setting('strategy', 'sgcm', 'sgcm (guidance) | greedy (baseline: no guidance)', choices=STRATEGIES),
    CAMERA,
    IMAGE_TRANSPORT,
    Setting('follower_timeout', 60.0, 'sim seconds to wait for the follower to end a round (applied to the '
            'wait in progress)', low=0.0, dynamic=True),
    Setting('settle_time', 0.5, 'sim seconds to let the table settle before observing (applied to the '
            'settling in progress)', low=0.0, dynamic=True),
    Setting('round_limit', 0, 'rounds before giving up; 0 = the task file game.round_limit (applied at the '
            'next observation)', low=0, dynamic=True),
    Setting('seed', 0, 'seed for sampling a mixed leader policy', low=0),
    Setting('moves_can_fail', True, "the arms' moves may fail by chance (the bridge's failure_probability > 0); "
            'false: a state that comes back after rounds without chance ends the task as stuck '
            '(sgcm.core.stuck_rule; a round with both arms idle ends it either way)'),
    PERCEPTION_FAULT_AFTER,
    Setting('follower', 'follower_arm/follower_executor', "the follower's node, under the team namespace: "
            'reports from any other sender are refused (sgcm.core.sessions)', check=_node_name_problem),
    Setting('exit_when_done', True, 'exit the node when the task has ended'),
)

FOLLOWER_SETTINGS = SettingsSchema(
    TASK_FILE,
    Setting('behaviour', 'obedient', 'how the follower chooses his move', choices=BEHAVIOURS),
    Setting('deviation_probability', 0.0, 'random behaviour: probability of a random move per round',
            low=0.0, high=1.0),
    Setting('deviation_rounds', [0], 'random behaviour: rounds with a random move, numbered from 1 (0 = none)',
            low=0),
    Setting('seed', 0, 'seed of the random behaviour', low=0),
    CAMERA,
    IMAGE_TRANSPORT,
    Setting('settle_time', 0.5, 'sim seconds after the guidance before observing the table (applied to the '
            'round in progress)', low=0.0, dynamic=True),
    PERCEPTION_FAULT_AFTER,
    Setting('leader', 'leader_arm/leader_planner', "the leader's node, under the team namespace: guidance from "
            'any other sender is refused (sgcm.core.sessions)', check=_node_name_problem),
    Setting('max_round_jump', MAX_ROUND_JUMP, 'rounds a guidance may run ahead of the last one heard in its '
            "session, and the highest round a new session of the leader may begin with (a restarted leader's "
            'first is 1): a forged round 2^32-1 is refused (sgcm.core.sessions)', low=1, high=1000),
    Setting('exit_when_done', True, 'exit when the leader announces the end of the task'),
)


def read_task_parameter(path: str) -> TaskConfig:
    """The task of the ``task_file`` parameter; its errors name the parameter and the field."""
    try:
        return load_task(path)
    except TaskConfigError as error:
        raise ConfigurationError(f'parameter task_file: {error}') from None


@dataclass(frozen=True)
class LeaderSettings:
    """The leader_planner's start values, checked, with its task."""

    task: TaskConfig
    horizon: int               # T; the task's game.horizon when the parameter is 0
    solver: str
    planner: str               # FSE path: kernel | reference
    strategy: str
    camera: str
    image_transport: str
    follower_timeout: float
    settle_time: float
    round_limit: int | None    # None: the task's game.round_limit
    seed: int
    moves_can_fail: bool
    exit_when_done: bool

    @classmethod
    def from_values(cls, values: Mapping[str, Any]) -> 'LeaderSettings':
        """``values``: LEADER_SETTINGS' validated values (as declare_schema returns them)."""
        task = read_task_parameter(values['task_file'])
        return cls(task=task, horizon=values['horizon'] or task.horizon, solver=values['solver'],
                   planner=values['planner'], strategy=values['strategy'], camera=values['camera'],
                   image_transport=values['image_transport'],
                   follower_timeout=values['follower_timeout'], settle_time=values['settle_time'],
                   round_limit=values['round_limit'] or None, seed=values['seed'],
                   moves_can_fail=values['moves_can_fail'], exit_when_done=values['exit_when_done'])


@dataclass(frozen=True)
class FollowerExecutorSettings:
    """The follower_executor's start values, checked, with its task."""

    task: TaskConfig
    follower: FollowerSettings
    seed: int
    camera: str
    image_transport: str
    settle_time: float
    exit_when_done: bool

    @classmethod
    def from_values(cls, values: Mapping[str, Any]) -> 'FollowerExecutorSettings':
        """``values``: FOLLOWER_SETTINGS' validated values (as declare_schema returns them)."""
        task = read_task_parameter(values['task_file'])
        rounds = tuple(int(r) for r in values['deviation_rounds'] if int(r) != 0)
        try:
            follower = FollowerSettings(values['behaviour'], values['deviation_probability'], rounds)
        except ValueError as error:  # the schema's ranges make this unreachable; name the parameter anyway
            raise ConfigurationError(f'parameter {error}') from None
        return cls(task=task, follower=follower, seed=values['seed'], camera=values['camera'],
                   image_transport=values['image_transport'], settle_time=values['settle_time'],
                   exit_when_done=values['exit_when_done'])

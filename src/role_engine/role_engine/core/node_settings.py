"""The ROS parameters of the role nodes as plain data (README "Role nodes: parameters").

Each node declares its schema with ``NodeParameters.declare_schema``; the unit tests check bad
values against the same schemas without starting a node.

* ``role_engine``: :data:`ENGINE_SETTINGS` (read-only: what the node is built from) and
  :func:`engine_tuning_schema` (dynamic: the next negotiation or problem check uses them);
* ``role_player``: :data:`PLAYER_SETTINGS` (read-only) and, once the team description names its
  robot's type, :func:`player_tuning_schema` (dynamic: the next command or re-plan);
* ``robot_tracker``: :data:`TRACKER_SETTINGS` (camera read-only, colour thresholds dynamic).

The tuning schemas take their defaults from the shared settings file's values (team-wide, so
they are built from a :class:`~.tuning.PlayerTuning` / :class:`~.tuning.EngineTuning`); a
start-up parameter wins. :func:`tuned` applies validated values to a tuning object, whose own
checks (e.g. a velocity cap above the robot type's limit) become ``ConfigurationError``
``parameter <name>: ...``. ``team_namespace`` and the player's ``robot`` are declared by
``collab_tools.names``.
"""
from __future__ import annotations

import re
from typing import Any, Mapping, Sequence, TypeVar

from collab_tools.core.errors import ConfigurationError
from collab_tools.core.settings import Setting, SettingsSchema

from pybullet_bridge.core.scenario import load_scenario

from .errors import RoleEngineError
from .formation_task import FormationTask, TeamMember, check_grid_size, load_formation_task, team_from_scenario
from .gp_planner import FORMULATIONS
from .tracking import TrackingSettings
from .tuning import EngineTuning, PlayerTuning

POSITIVE = {'low': 0.0, 'low_open': True}
NON_NEGATIVE = {'low': 0.0}


def _namespace(value: str) -> str | None:
    return None if value.strip('/') else 'must be a non-empty namespace'


CAMERA = Setting('camera', 'top_camera', "the top camera's namespace, relative to the team namespace",
                 check=_namespace)

ENGINE_SETTINGS = SettingsSchema(
    Setting('settings_file', '', 'formation settings YAML (config/roles/formation_demo.yaml): the scenario, the '
            'formation and the team-wide defaults of the tuning parameters', required=True),
    CAMERA,
    Setting('exit_when_done', False, 'exit once the formation is complete or the task is aborted'),
)

def _node_name(value: str) -> str | None:
    return None if re.fullmatch(r'[A-Za-z_][A-Za-z0-9_]*', value) else \
        f'must be a ROS node name: letters, digits and _, not starting with a digit (got {value[:60]!r})'


PLAYER_SETTINGS = SettingsSchema(
    Setting('settings_file', '', 'formation settings YAML (config/roles/formation_demo.yaml): the team-wide '
            'defaults of the tuning parameters (its scenario is not read: the team and the map come from the '
            'role engine)', required=True),
    Setting('engine', 'role_engine', "the role engine's node name in the team namespace: the player follows the "
            'assignments this node sends (its current session) and ignores other senders (core.sessions)',
            check=_node_name),
)

TRACKER_SETTINGS = SettingsSchema(
    CAMERA,
    Setting('chroma_tolerance', TrackingSettings.chroma_tolerance,
            "largest chromaticity distance (rgb / (r + g + b)) of a robot's pixel from its colour; from the next "
            'frame', low=0.0, low_open=True, high=1.0, dynamic=True),
    Setting('min_brightness', TrackingSettings.min_brightness,
            'r + g + b (0..765) below which a pixel is too dark to match a colour (and dark enough to be the '
            'heading marker); from the next frame', low=0.0, high=765.0, dynamic=True),
    Setting('min_area_px', TrackingSettings.min_area_px, 'smallest blob (pixels) taken for a robot; from the next '
            'frame', low=1, dynamic=True),
)

#: role_player tuning: name -> (description, constraints); defaults from the settings file.
PLAYER_TUNING: dict[str, tuple[str, dict]] = {
    'replan_period': ('s between re-optimisations of the role, each also publishing it on the channel (the '
                      "heartbeat: keep it below the engine's silence_timeout); from the next period", POSITIVE),
    'arrival_tolerance': ('m from the destination at which the robot has arrived (the controller stops within '
                          'half of it); from the next command', POSITIVE),
    'conflict_horizon': ("s of the others' roles checked for conflicts; from the next re-plan", NON_NEGATIVE),
    'speed_fraction': ("GP speed limit of a re-plan (Eq. 22) as a share of max_linear_velocity; from the next "
                       're-plan', {'low': 0.0, 'low_open': True, 'high': 1.0}),
    'max_linear_velocity': ("m/s cap of the commands, at most the robot type's limit (the default); re-plans keep "
                            'under it too; from the next command', POSITIVE),
    'max_angular_velocity': ("rad/s cap of the commands, at most the robot type's limit (the default); from the "
                             'next command', POSITIVE),
    'controller.k_x': ('1/s, tracking gain on the along-track error; from the next command', POSITIVE),
    'controller.k_y': ('1/m^2, tracking gain on the cross-track error; from the next command', POSITIVE),
    'controller.k_theta': ('1/m, tracking gain on the heading error; from the next command', POSITIVE),
    'controller.k_approach': ('1/s, approach gain toward a reference at rest; from the next command', POSITIVE),
    'controller.k_turn': ('1/s, turning gain toward a reference at rest; from the next command', POSITIVE),
    'robot_avoidance.clearance': ('m kept beyond r_i + r_j from the other robots; from the next re-plan',
                                  NON_NEGATIVE),
    'robot_avoidance.sigma': ('m, std of the inter-robot hinge (smaller = stiffer); from the next re-plan',
                              POSITIVE),
    'robot_avoidance.interpolation': ('GP-interpolated instants per interval also compared with the others; '
                                      'from the next re-plan', {'low': 0}),
    'robot_avoidance.detour_scales': ('sideways detours tried around a head-on conflict, in units of r_i + r_j + '
                                      'clearance; 0 entries are skipped ([0.0] = no detour); from the next re-plan',
                                      NON_NEGATIVE),
    'gp.epsilon': ('m, safety distance of the obstacle hinge (Eq. 21); from the next re-plan', NON_NEGATIVE),
    'gp.sigma_obs': ('m, std of the obstacle hinge (Eq. 9, 21); from the next re-plan', POSITIVE),
    'gp.lambda_initial': ('initial Levenberg-Marquardt damping; from the next re-plan', POSITIVE),
    'gp.max_iterations': ('Levenberg-Marquardt iteration cap of a re-plan (its compute budget); from the next '
                          're-plan', {'low': 1}),
    'gp.relative_error_tol': ('Levenberg-Marquardt relative-decrease stop; from the next re-plan', NON_NEGATIVE),
    'gp.obstacle_interpolation': ('GP-interpolated obstacle factors per interval; from the next re-plan',
                                  {'low': 0}),
    'gp.formulation': ('GP solver of a re-plan; from the next re-plan', {'choices': FORMULATIONS}),
}

#: role_engine tuning: name -> (description, constraints); defaults from the settings file.
ENGINE_TUNING: dict[str, tuple[str, dict]] = {
    'start_delay': ("s from publishing an assignment to its roles' start time; from the next negotiation",
                    NON_NEGATIVE),
    'qualification_lambda': ('lambda of Q = lambda F_gp + F_conf (Eq. 13); from the next negotiation', NON_NEGATIVE),
    'min_robots': ('fewer usable robots than this after a problem: the task is aborted; from the next '
                   'renegotiation', {'low': 1}),
    'silence_timeout': ('s without a process role before a robot counts as silent; from the next check',
                        POSITIVE),
    'problem_detection.stuck_distance': ('m: a robot that moved no more than this over stuck_time while its role '
                                         'asked for more is stuck; from the next check', POSITIVE),
    'problem_detection.stuck_time': ('s of the stuck window; from the next check', POSITIVE),
    'problem_detection.off_role_distance': ('m from where its role puts it beyond which a robot is off its role; '
                                            'from the next check', POSITIVE),
    'problem_detection.off_role_grace': ('s a robot may stay off its role; from the next check', NON_NEGATIVE),
}


def _tuning_schema(table: Mapping[str, tuple[str, dict]], defaults: Mapping[str, Any],
                   high: Mapping[str, float]) -> SettingsSchema:
    settings = []
    for name, (description, constraints) in table.items():
        constraints = dict(constraints)
        if name in high:
            constraints['high'] = high[name]
        settings.append(Setting(name, defaults[name], description, dynamic=True, **constraints))
    return SettingsSchema(*settings)


def engine_tuning_schema(tuning: EngineTuning) -> SettingsSchema:
    """The role engine's dynamic parameters, defaults from ``tuning`` (the settings file's values)."""
    return _tuning_schema(ENGINE_TUNING, tuning.values(), {})


def player_tuning_schema(tuning: PlayerTuning) -> SettingsSchema:
    """A role player's dynamic parameters: defaults from ``tuning``, velocity caps at most its type's limits."""
    limits = tuning.robot_type
    return _tuning_schema(PLAYER_TUNING, tuning.values(), {'max_linear_velocity': limits.max_linear_velocity,
                                                           'max_angular_velocity': limits.max_angular_velocity})


Tuning = TypeVar('Tuning', EngineTuning, PlayerTuning)


def tuned(tuning: Tuning, values: Mapping[str, Any]) -> Tuning:
    """``tuning`` with ``values`` (flat parameter names) applied; ConfigurationError naming the parameter."""
    try:
        return tuning.with_values(values)
    except RoleEngineError as error:
        raise ConfigurationError(f'parameter {error}') from None


def tracking_settings(values: Mapping[str, Any]) -> TrackingSettings:
    """The colour thresholds of the tracker's parameter values (the camera is not one of them)."""
    return TrackingSettings(**{name: values[name] for name in TRACKER_SETTINGS.names if name != 'camera'})


def engine_settings_file(path: str):
    """The engine's settings file: (task, bridge scenario, team), or ConfigurationError naming the parameter."""
    try:
        task = load_formation_task(path)
        scenario = load_scenario(task.scenario)
        check_grid_size(task, scenario.world.bounds)
        return task, scenario, team_from_scenario(scenario, task.inflation_margin)
    except ValueError as error:          # RoleEngineError and the bridge's ScenarioError
        raise ConfigurationError(f'parameter settings_file: {error}') from None


def player_settings_file(path: str) -> FormationTask:
    """A player's settings file: the formation task, its scenario not read (the team and the map come from
    the engine), or ConfigurationError naming the parameter."""
    try:
        return load_formation_task(path, check_scenario=False)
    except ValueError as error:
        raise ConfigurationError(f'parameter settings_file: {error}') from None


def team_member(team: Sequence[TeamMember], robot: str, namespace: str) -> TeamMember:
    """A player's robot in the team description, or ConfigurationError naming the robots there are."""
    members = {m.name: m for m in team}
    if robot not in members:
        raise ConfigurationError(f"parameter robot: must be one of {', '.join(members)} (got {robot!r}, "
                                 f'the last component of the namespace {namespace})')
    return members[robot]

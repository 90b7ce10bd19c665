"""The tuning parameters of the role nodes: one table per node (README "Role nodes: parameters").

Every entry is dynamic: the node replaces its tuning object (core.tuning) when the parameter is
set, and reads that object at every use, so the value applies from the next re-plan, command or
check. The defaults are the shared settings file's values (team-wide); a start-up parameter wins.
The nodes' other parameters (settings_file, team_namespace; the engine's camera and exit_when_done;
the player's robot) are read-only: they decide what the node is built from.
"""
from __future__ import annotations

from collections.abc import Callable
from typing import Any

from collab_tools.node_support import ConfigurationError
from collab_tools.parameters import NodeParameters

from .core.errors import RoleEngineError
from .core.gp_planner import FORMULATIONS

POSITIVE = {'low': 0.0, 'low_open': True}
NON_NEGATIVE = {'low': 0.0}

#: role_player: name -> (description, constraints for NodeParameters.declare)
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

#: role_engine: name -> (description, constraints)
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


def declare_tuning(params: NodeParameters, tuning, table: dict[str, tuple[str, dict]],
                   apply: Callable[[str, Any], None], high: dict[str, float] | None = None):
    """Declare every entry of ``table`` with ``tuning``'s value as default; returns the tuning with the
    start-up values (ConfigurationError naming the parameter). ``apply(name, value)`` runs on a set."""
    defaults = tuning.values()
    for name, (description, constraints) in table.items():
        constraints = dict(constraints)
        if high and name in high:
            constraints['high'] = high[name]
        params.declare(name, defaults[name], description, on_change=lambda value, name=name: apply(name, value),
                       **constraints)
    try:
        return tuning.with_values({name: params[name] for name in table})
    except RoleEngineError as error:
        raise ConfigurationError(f'parameter {error}') from None

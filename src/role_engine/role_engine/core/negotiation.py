"""Role negotiation and feasibility check (Sec. III-A, Algorithm 2).

For every robot type present among the agents: its environment view ``Env_tau``, SDF
``Sdf_tau`` and E-Map; then for every agent and role the auxiliary nodes on the agent's
E-Map and the initial process role along them (or none when unreachable). The problem
is infeasible when some role cannot be reached by any agent (line 12); whether the
roles can be filled *together* is decided by GRA (:mod:`.assignment`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .astar import AuxiliaryPath, EMapPlanner
from .emap import EMap, build_emap
from .environment import Environment, RobotEnvironment, RobotType
from .errors import RoleEngineError
from .initial_paths import polyline_trajectory, state_times


@dataclass(frozen=True)
class Agent:
    """A robot: its name, type and current position (world x, y)."""

    name: str
    robot_type: RobotType
    position: tuple[float, float]


@dataclass(frozen=True)
class Role:
    """A role: reach ``destination`` (world x, y). Roles are unlabeled: any agent may take any."""

    name: str
    destination: tuple[float, float]


@dataclass
class NegotiationResult:
    """Output of Algorithm 2 (``Feasibility, Env_tau, Sdf_tau, Init_paths``).

    ``paths[(i, j)]`` is the auxiliary path of agent i to role j (feasible or with its
    reason); ``initial_trajectories`` holds the (N+1, 4) initial process roles of the
    feasible pairs only. ``reasons`` explains an infeasible result.
    """

    agents: list[Agent]
    roles: list[Role]
    total_time: float
    num_intervals: int
    robot_envs: dict[str, RobotEnvironment]
    emaps: dict[str, EMap]
    paths: dict[tuple[int, int], AuxiliaryPath]
    initial_trajectories: dict[tuple[int, int], np.ndarray]
    feasible: bool
    reasons: list[str] = field(default_factory=list)

    def reachable(self) -> np.ndarray:
        """(m, n) bool: which agent can reach which role."""
        table = np.zeros((len(self.agents), len(self.roles)), dtype=bool)
        for (i, j) in self.initial_trajectories:
            table[i, j] = True
        return table


def _check_inputs(agents: list[Agent], roles: list[Role]) -> None:
    if not agents:
        raise RoleEngineError('agents: need at least one agent')
    if not roles:
        raise RoleEngineError('roles: need at least one role')
    for kind, items in (('agents', agents), ('roles', roles)):
        names = [item.name for item in items]
        duplicates = sorted({n for n in names if names.count(n) > 1})
        if duplicates:
            raise RoleEngineError(f"{kind}: names must be unique (repeated: {', '.join(duplicates)})")
    types: dict[str, RobotType] = {}
    for index, agent in enumerate(agents):
        known = types.setdefault(agent.robot_type.name, agent.robot_type)
        if known != agent.robot_type:
            raise RoleEngineError(f"agents[{index}].robot_type: two different definitions of type "
                                  f"'{agent.robot_type.name}'")
        point = np.asarray(agent.position, dtype=float)
        if point.shape != (2,) or not np.isfinite(point).all():
            raise RoleEngineError(f'agents[{index}].position: must be a finite (x, y) (got {agent.position})')
    for index, role in enumerate(roles):
        point = np.asarray(role.destination, dtype=float)
        if point.shape != (2,) or not np.isfinite(point).all():
            raise RoleEngineError(f'roles[{index}].destination: must be a finite (x, y) (got {role.destination})')


def negotiate_roles(agents: list[Agent], roles: list[Role], environment: Environment, *,
                    total_time: float, num_intervals: int, corner_tolerance: float = 1.5,
                    use_emap: bool = True) -> NegotiationResult:
    """Algorithm 2. ``use_emap=False`` gives the straight-line initialisation of plain GPMP
    (every pair gets a straight initial path; feasibility is then left to the planner)."""
    agents, roles = list(agents), list(roles)
    _check_inputs(agents, roles)
    state_times(total_time, num_intervals)  # validates the timing once, with the field names
    robot_envs: dict[str, RobotEnvironment] = {}
    emaps: dict[str, EMap] = {}
    planners: dict[str, EMapPlanner] = {}
    for agent in agents:                                           # lines 2-6
        name = agent.robot_type.name
        if name not in robot_envs:
            robot_envs[name] = environment.for_robot(agent.robot_type)
            if use_emap:
                emaps[name] = build_emap(robot_envs[name], corner_tolerance=corner_tolerance)
                planners[name] = EMapPlanner(emaps[name])
    paths: dict[tuple[int, int], AuxiliaryPath] = {}
    trajectories: dict[tuple[int, int], np.ndarray] = {}
    for i, agent in enumerate(agents):                             # lines 7-11
        for j, role in enumerate(roles):
            if use_emap:
                path = planners[agent.robot_type.name].plan(agent.position, role.destination)
            else:
                waypoints = np.array([agent.position, role.destination], dtype=float)
                path = AuxiliaryPath(True, waypoints, waypoints, float(math.dist(*waypoints)))
            paths[(i, j)] = path
            if path.feasible:
                trajectories[(i, j)] = polyline_trajectory(path.waypoints, total_time, num_intervals)
    reasons = []
    for j, role in enumerate(roles):                               # lines 12-14
        if not any((i, j) in trajectories for i in range(len(agents))):
            why = '; '.join(f'{agents[i].name}: {paths[(i, j)].reason}' for i in range(len(agents)))
            reasons.append(f"role '{role.name}' at ({role.destination[0]:.3f}, {role.destination[1]:.3f}) "
                           f'cannot be reached by any agent ({why})')
    return NegotiationResult(agents, roles, float(total_time), int(num_intervals), robot_envs, emaps,
                             paths, trajectories, not reasons, reasons)

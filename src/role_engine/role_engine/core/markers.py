"""The role engine as markers: E-Maps, assigned roles, each robot's process role and where it is now.

Built from the role engine's own topics (``roles/map`` nav_msgs/OccupancyGrid, ``roles/team``,
``roles/assignment``, ``roles/channel`` ProcessRole) into plain
:class:`~collab_tools.core.marker_specs.MarkerSpec` lists in the world frame, published by the
visualiser node on ``markers/roles``. Messages are read by attribute only (unit tests use stand-ins).

Marker namespaces: ``emap/<robot type>`` (the E-Map graph of each robot type of the team, built
with :func:`.emap.build_emap` on the map the engine published: edges as lines, feature nodes as
spheres), ``goals`` (each assigned role's destination, in its robot's colour) and ``roles`` (robot:
role id), ``process_roles`` (each robot's latest process role, a time-indexed path),
``now`` (the state of that path at the current time: where the role says the robot should be).
"""
from __future__ import annotations

import math

import numpy as np

from collab_tools.core.marker_specs import MarkerInput, MarkerSpec, finite, palette, rgba

from .emap import EMap, build_emap
from .environment import Environment, RobotType
from .occupancy import OccupancyCells, environment_from_cells, quaternion_yaw

PATH_Z, GOAL_Z, TEXT_Z = 0.02, 0.01, 0.5
#: What a status text shows of the engine's message (an infeasible round explains every role).
STATUS_CHARS = 160


def environment_of_grid(msg) -> Environment:
    """nav_msgs/OccupancyGrid (by attribute) -> Environment; RoleEngineError naming the field."""
    info, q = msg.info, msg.info.origin.orientation
    cells = OccupancyCells(info.width, info.height, info.resolution,
                           (info.origin.position.x, info.origin.position.y), np.asarray(msg.data, dtype=np.int8))
    return environment_from_cells(cells, origin_yaw=quaternion_yaw(q.x, q.y, q.z, q.w), name='roles/map')


def emaps_of(environment: Environment, team) -> dict[str, EMap]:
    """One E-Map per robot type of the team (Team message members, by attribute), as the engine builds them."""
    emaps: dict[str, EMap] = {}
    for member in team.members:
        kind = str(member.robot_type or 'robot')
        if kind not in emaps:
            emaps[kind] = build_emap(environment.for_robot(RobotType(kind, float(member.radius))))
    return emaps


def emap_markers(emap: EMap, kind: str, index: int, frame: str) -> list[MarkerSpec]:
    colour = palette(index, 0.8)
    pairs = []
    for a, b in emap.graph.edges:
        (xa, ya), (xb, yb) = emap.position(a), emap.position(b)
        pairs += [(xa, ya, PATH_Z), (xb, yb, PATH_Z)]
    nodes = tuple((float(x), float(y), PATH_Z) for x, y in (emap.position(n) for n in emap.node_ids))
    specs = []
    if pairs:
        specs.append(MarkerSpec(f'emap/{kind}', 0, 'line_list', frame, scale=(0.02, 0, 0), color=colour,
                                points=tuple(pairs)))
    if nodes:
        specs.append(MarkerSpec(f'emap/{kind}', 1, 'sphere_list', frame, scale=(0.08, 0.08, 0.08), color=colour,
                                points=nodes))
    return specs


def _check_lengths(msg, names: tuple[str, ...], where: str) -> int:
    lengths = {name: len(getattr(msg, name)) for name in names}
    if len(set(lengths.values())) > 1:
        raise ValueError(f'{where}: parallel arrays differ in length ({lengths})')
    return next(iter(lengths.values()), 0)


def assignment_markers(assignment, colours: dict[str, tuple], frame: str) -> list[MarkerSpec]:
    """Each assigned role's destination (a disc in its robot's colour) with 'robot: role' above it."""
    count = _check_lengths(assignment, ('robots', 'role_ids', 'goal_x', 'goal_y'), 'roles/assignment')
    specs = []
    for i in range(count):
        robot, role = str(assignment.robots[i]), str(assignment.role_ids[i])
        x, y = float(assignment.goal_x[i]), float(assignment.goal_y[i])
        if not (math.isfinite(x) and math.isfinite(y)):
            raise ValueError(f'roles/assignment.goal_x/goal_y[{i}]: not finite')
        colour = colours.get(robot, palette(i))
        specs.append(MarkerSpec('goals', i, 'cylinder', frame, position=(x, y, GOAL_Z), scale=(0.25, 0.25, 0.02),
                                color=(colour[0], colour[1], colour[2], 0.6)))
        specs.append(MarkerSpec('roles', i, 'text', frame, position=(x, y, TEXT_Z), scale=(0, 0, 0.15),
                                text=f'{robot}: {role}'))
    message = str(assignment.message)
    message = message if len(message) <= STATUS_CHARS else message[:STATUS_CHARS - 3] + '...'
    status = f'round {int(assignment.round)}: {assignment.status}' + (f' ({message})' if message else '')
    specs.append(MarkerSpec('roles', count, 'text', frame, position=(0.0, 0.0, 2 * TEXT_Z), scale=(0, 0, 0.2),
                            text=status))
    return specs


def role_state_at(role, now: float) -> tuple[float, float]:
    """(x, y) of a process role at time ``now`` (clamped to its first and last state)."""
    n = _check_lengths(role, ('x', 'y'), f'process role of {role.robot}')
    if n == 0:
        raise ValueError(f'process role of {role.robot}: no states')
    dt = float(role.dt)
    if not (math.isfinite(dt) and dt > 0):
        raise ValueError(f'process role of {role.robot}.dt: must be > 0 (got {role.dt})')
    t = (now - float(role.start_time)) / dt
    k = min(max(t, 0.0), n - 1.0)
    i = min(int(k), n - 2) if n > 1 else 0
    f = k - i if n > 1 else 0.0
    x = float(role.x[i]) + f * (float(role.x[min(i + 1, n - 1)]) - float(role.x[i]))
    y = float(role.y[i]) + f * (float(role.y[min(i + 1, n - 1)]) - float(role.y[i]))
    return x, y


def process_role_markers(roles: dict, colours: dict[str, tuple], now: float, frame: str) -> list[MarkerSpec]:
    """Each robot's process role as a path, and the point of it that belongs to ``now``."""
    specs = []
    for index, (robot, role) in enumerate(sorted(roles.items())):
        colour = colours.get(robot, palette(index))
        points = tuple((float(x), float(y), PATH_Z) for x, y in zip(role.x, role.y)
                       if math.isfinite(float(x)) and math.isfinite(float(y)))
        if len(points) >= 2:
            specs.append(MarkerSpec('process_roles', index, 'line_strip', frame, scale=(0.03, 0, 0),
                                    color=(colour[0], colour[1], colour[2], 0.9), points=points))
        x, y = role_state_at(role, now)
        specs.append(MarkerSpec('now', index, 'sphere', frame, position=(x, y, PATH_Z), scale=(0.15, 0.15, 0.15),
                                color=(colour[0], colour[1], colour[2], 1.0)))
    return specs


def _session(msg) -> int:
    """The engine session of an assignment or process role (0 in recordings made before sessions)."""
    return int(getattr(msg, 'session', 0))


class RoleMarkers:
    """The visualiser's role engine source (collab_tools.core.marker_specs)."""

    INPUTS = (MarkerInput('roles/map', 'nav_msgs/msg/OccupancyGrid', 'latched', 'on_map'),
              MarkerInput('roles/team', 'role_interfaces/msg/Team', 'latched', 'on_team'),
              MarkerInput('roles/assignment', 'role_interfaces/msg/RoleAssignment', 'latched', 'on_assignment'),
              MarkerInput('roles/channel', 'role_interfaces/msg/ProcessRole', 'reliable', 'on_process_role'))
    time_dependent = True  # the current state moves along each process role

    def __init__(self, world_frame: str = 'world'):
        self.frame = world_frame
        self.environment: Environment | None = None
        self.team = None
        self.emaps: dict[str, EMap] = {}
        self.colours: dict[str, tuple] = {}
        self.assignment = None
        self.roles: dict[str, object] = {}

    def on_map(self, msg, topic: str = '') -> None:
        self.environment = environment_of_grid(msg)
        self._build_emaps()

    def on_team(self, msg, topic: str = '') -> None:
        for member in msg.members:  # refuse a robot type no E-Map can be built for before keeping it
            RobotType(str(member.robot_type or 'robot'), float(member.radius))
        self.colours = {str(m.name): rgba(m.color) for m in msg.members}
        self.team = msg
        self._build_emaps()

    def _build_emaps(self) -> None:
        if self.environment is not None and self.team is not None:
            self.emaps = emaps_of(self.environment, self.team)

    def on_assignment(self, msg, topic: str = '') -> None:
        _check_lengths(msg, ('robots', 'role_ids', 'goal_x', 'goal_y'), 'roles/assignment')
        if not finite(*msg.goal_x, *msg.goal_y):  # kept, it would stop every later picture
            raise ValueError('roles/assignment.goal_x/goal_y: not finite')
        previous, self.assignment = self.assignment, msg
        new_session = previous is not None and _session(previous) != _session(msg)
        if new_session or int(msg.round) > max((int(r.round) for r in self.roles.values()), default=0):
            self.roles = {}  # a new round, or a restarted engine's session: the old process roles are over
        for role in msg.initial_roles:
            self.on_process_role(role)

    def on_process_role(self, msg, topic: str = '') -> None:
        role_state_at(msg, float(msg.start_time))  # refuse what cannot be drawn before keeping it
        if not finite(*msg.x, *msg.y):
            raise ValueError(f'process role of {msg.robot}.x/y: not finite')
        if self.assignment is not None and _session(msg) != _session(self.assignment):
            return  # a role of an engine session that is over (or not assigned yet)
        have = self.roles.get(str(msg.robot))
        if have is None or (int(msg.round), int(msg.version)) >= (int(have.round), int(have.version)):
            self.roles[str(msg.robot)] = msg

    def markers(self, now: float = 0.0) -> list[MarkerSpec] | None:
        if self.environment is None and self.assignment is None and not self.roles:
            return None
        specs = []
        for index, (kind, emap) in enumerate(sorted(self.emaps.items())):
            specs += emap_markers(emap, kind, index, self.frame)
        if self.assignment is not None:
            specs += assignment_markers(self.assignment, self.colours, self.frame)
        specs += process_role_markers(self.roles, self.colours, now, self.frame)
        return specs

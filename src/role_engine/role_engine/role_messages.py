"""Role messages <-> core objects: ProcessRole <-> (N+1, 4) process-role arrays, Team <-> team
members, nav_msgs/OccupancyGrid <-> Environment (core.occupancy), tracked poses.

Every reader validates what it gets and raises ValueError naming the field (a MalformedInput with
its kind where the kind is not the field), so the nodes' input guard (collab_tools.input_guard)
drops, counts and logs it; what passes can be played without an error later (a process role
within the bounds below builds a controller: core.controller.TrajectoryFollower).
"""
from __future__ import annotations

import math
from collections.abc import Collection

import numpy as np
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import OccupancyGrid
from role_interfaces.msg import ProcessRole, Team, TeamMember as TeamMemberMsg

from collab_tools.core.input_checks import MalformedInput, error_kind

from .core.conflict import SharedRole
from .core.environment import Environment, RobotType
from .core.errors import RoleEngineError
from .core.formation_task import TeamMember
from .core.occupancy import OccupancyCells, environment_from_cells, occupancy_cells, quaternion_yaw

#: Bounds of a process role on the wire, far beyond any formation's and well inside what a player can
#: hold: states per role (a GP role has tens), its duration (the controller samples it every
#: core.trajectory.PROJECTION_STEP s: at most 180,000 samples), |x|, |y| in m, |vx|, |vy| in m/s, the radius in m, the start time in s.
MAX_ROLE_STATES = 10_000
MAX_ROLE_SECONDS = 3_600.0
MAX_ROLE_COORDINATE = 10_000.0
MAX_ROLE_SPEED = 1_000.0
MAX_ROLE_RADIUS = 100.0
MAX_START_TIME = 2.0**31


def process_role_msg(robot: str, role_id: str, round_: int, version: int, start_time: float,
                     total_time: float, radius: float, trajectory: np.ndarray, arrived: bool = False, *,
                     sender: str = '', session: int = 0) -> ProcessRole:
    """``sender``: the publishing node's full name; ``session``: the engine session (core.sessions)."""
    states = np.asarray(trajectory, dtype=float)
    return ProcessRole(sender=sender, session=int(session), robot=robot, role_id=role_id, round=int(round_),
                       version=int(version),
                       start_time=float(start_time), dt=float(total_time) / (len(states) - 1), radius=float(radius),
                       x=states[:, 0].tolist(), y=states[:, 1].tolist(), vx=states[:, 2].tolist(),
                       vy=states[:, 3].tolist(), arrived=bool(arrived))


def trajectory_of(msg: ProcessRole) -> np.ndarray:
    """(N+1, 4) states of a message; ValueError when the arrays disagree or are too short."""
    lengths = {len(msg.x), len(msg.y), len(msg.vx), len(msg.vy)}
    if len(lengths) != 1 or not 2 <= min(lengths) <= max(lengths) <= MAX_ROLE_STATES:
        raise MalformedInput(kind='process role: arrays', message=f'process role of {msg.robot[:40]!r}: x, y, vx, vy must have one equal length in '
                         f'[2, {MAX_ROLE_STATES}] (got {len(msg.x)}, {len(msg.y)}, {len(msg.vx)}, {len(msg.vy)})')
    if not (msg.dt > 0 and np.isfinite(msg.dt) and msg.dt * (len(msg.x) - 1) <= MAX_ROLE_SECONDS):
        raise MalformedInput(kind='process role: dt', message=f'process role of {msg.robot[:40]!r}: dt must be '
                             f'> 0 and the role at most {MAX_ROLE_SECONDS:g} s long (got dt {msg.dt} for '
                             f'{len(msg.x) - 1} steps)')
    return np.column_stack([msg.x, msg.y, msg.vx, msg.vy]).astype(float)


def shared_role(msg: ProcessRole, team: Collection[str] | None = None) -> SharedRole:
    """The message as a SharedRole; ValueError naming the field when it is malformed, MalformedInput
    ``unknown robot`` when ``team`` (robot names) is given and does not name its robot."""
    if not msg.robot:
        raise MalformedInput('process role: robot must be a non-empty name', kind='process role: no robot')
    if team is not None and msg.robot not in team:
        raise MalformedInput(f'process role: robot {msg.robot[:40]!r} is not in the team', kind='unknown robot')
    states = trajectory_of(msg)
    if not np.isfinite(states).all():
        raise MalformedInput(f'process role of {msg.robot!r}: x, y, vx, vy must be finite',
                             kind='process role: not finite')
    if np.abs(states[:, :2]).max() > MAX_ROLE_COORDINATE or np.abs(states[:, 2:]).max() > MAX_ROLE_SPEED:
        raise MalformedInput(f'process role of {msg.robot!r}: x, y must be within +-{MAX_ROLE_COORDINATE:g} m and '
                             f'vx, vy within +-{MAX_ROLE_SPEED:g} m/s', kind='process role: out of bounds')
    if not (np.isfinite(msg.radius) and 0 <= msg.radius <= MAX_ROLE_RADIUS):
        raise MalformedInput(f'process role of {msg.robot!r}: radius must be in [0, {MAX_ROLE_RADIUS:g}] m '
                             f'(got {msg.radius})', kind='process role: radius')
    if not (np.isfinite(msg.start_time) and abs(msg.start_time) <= MAX_START_TIME):
        raise MalformedInput(f'process role of {msg.robot!r}: start_time must be finite, within '
                             f'+-{MAX_START_TIME:g} s (got {msg.start_time})', kind='process role: start_time')
    return SharedRole(msg.robot, states, msg.dt * (len(states) - 1), msg.radius, msg.start_time)


def channel_role(msg: ProcessRole, team: Collection[str]) -> SharedRole:
    """A process role heard on the channel (:func:`shared_role`); its errors say it was dropped, keeping
    the field's kind for the input guard's counts."""
    try:
        return shared_role(msg, team)
    except ValueError as error:
        raise MalformedInput(f'dropped malformed process role: {error}', kind=error_kind(error)) from None


# --- the team (role_engine -> role players, robot tracker) -------------------------------------
def team_msg(team: list[TeamMember], frame_id: str) -> Team:
    """The team as the latched Team message (header.frame_id: the world frame of poses and map)."""
    msg = Team()
    msg.header.frame_id = frame_id
    for member in team:
        kind = member.robot_type
        msg.members.append(TeamMemberMsg(
            name=member.name, robot_type=kind.name, radius=float(kind.radius), height=float(member.height),
            color=[float(c) for c in member.color], max_linear_velocity=float(kind.max_linear_velocity),
            max_angular_velocity=float(kind.max_angular_velocity)))
    return msg


def team_of(msg: Team, inflation_margin: float) -> list[TeamMember]:
    """The members of a Team message with the planners' inflation margin; ValueError naming the field."""
    team, names = [], set()
    for index, member in enumerate(msg.members):
        where = f'team.members[{index}]'
        if not member.name or member.name in names:
            raise ValueError(f'{where}.name: must be a non-empty name used once (got {member.name!r})')
        names.add(member.name)
        try:
            kind = RobotType(member.robot_type or 'robot', float(member.radius), inflation_margin=inflation_margin,
                             max_linear_velocity=float(member.max_linear_velocity),
                             max_angular_velocity=float(member.max_angular_velocity))
        except RoleEngineError as error:
            raise ValueError(f'{where} ({member.name}): {error}') from None
        if kind.radius <= 0.0:
            raise ValueError(f'{where}.radius: must be > 0 (got {member.radius})')
        color = tuple(float(c) for c in member.color)
        if not all(math.isfinite(c) and 0.0 <= c <= 1.0 for c in color) or sum(color) <= 0.0:
            raise ValueError(f'{where}.color: must be r g b in [0, 1], not all zero (got {color})')
        if not (math.isfinite(member.height) and member.height >= 0.0):
            raise ValueError(f'{where}.height: must be finite and >= 0 (got {member.height})')
        team.append(TeamMember(member.name, kind, color, float(member.height)))
    if not team:
        raise ValueError('team.members: the team has no robot')
    return team


# --- the round's map (role_engine -> role players) ---------------------------------------------
def occupancy_grid_msg(environment: Environment, frame_id: str, stamp) -> OccupancyGrid:
    """The environment as a nav_msgs/OccupancyGrid (Nav2 conventions, core.occupancy)."""
    cells = occupancy_cells(environment)
    msg = OccupancyGrid()
    msg.header.frame_id = frame_id
    msg.header.stamp = stamp
    msg.info.map_load_time = stamp
    msg.info.resolution = float(cells.resolution)
    msg.info.width, msg.info.height = cells.width, cells.height
    msg.info.origin.position.x, msg.info.origin.position.y = cells.origin
    msg.info.origin.orientation.w = 1.0
    msg.data = cells.data.tolist()
    return msg


def environment_of(msg: OccupancyGrid, name: str = 'map') -> Environment:
    """The environment of an OccupancyGrid; ValueError (RoleEngineError) naming the field."""
    info, q = msg.info, msg.info.origin.orientation
    cells = OccupancyCells(info.width, info.height, info.resolution,
                           (info.origin.position.x, info.origin.position.y), np.asarray(msg.data, dtype=np.int8))
    return environment_from_cells(cells, origin_yaw=quaternion_yaw(q.x, q.y, q.z, q.w), name=name)


# --- tracked poses (robot_tracker -> role players) ---------------------------------------------
def pose_msg(x: float, y: float, yaw: float, frame_id: str, stamp) -> PoseStamped:
    msg = PoseStamped()
    msg.header.frame_id = frame_id
    msg.header.stamp = stamp
    msg.pose.position.x, msg.pose.position.y = float(x), float(y)
    msg.pose.orientation.z, msg.pose.orientation.w = math.sin(yaw / 2.0), math.cos(yaw / 2.0)
    return msg


def planar_pose(msg: PoseStamped) -> tuple[float, float, float]:
    """(x, y, yaw) of a pose; ValueError when it is not finite."""
    p, q = msg.pose.position, msg.pose.orientation
    pose = (float(p.x), float(p.y), quaternion_yaw(q.x, q.y, q.z, q.w))
    if not all(math.isfinite(v) for v in pose) or not any((q.x, q.y, q.z, q.w)):
        raise ValueError(f'tracked pose: position and orientation must be finite and set (got {pose})')
    return pose

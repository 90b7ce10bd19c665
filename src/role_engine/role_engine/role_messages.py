"""ProcessRole messages <-> (N+1, 4) process-role arrays."""
from __future__ import annotations

import numpy as np
from role_interfaces.msg import ProcessRole

from .core.conflict import SharedRole


def process_role_msg(robot: str, role_id: str, round_: int, version: int, start_time: float,
                     total_time: float, radius: float, trajectory: np.ndarray, arrived: bool = False) -> ProcessRole:
    states = np.asarray(trajectory, dtype=float)
    return ProcessRole(robot=robot, role_id=role_id, round=int(round_), version=int(version),
                       start_time=float(start_time), dt=float(total_time) / (len(states) - 1), radius=float(radius),
                       x=states[:, 0].tolist(), y=states[:, 1].tolist(), vx=states[:, 2].tolist(),
                       vy=states[:, 3].tolist(), arrived=bool(arrived))


def trajectory_of(msg: ProcessRole) -> np.ndarray:
    """(N+1, 4) states of a message; ValueError when the arrays disagree or are too short."""
    lengths = {len(msg.x), len(msg.y), len(msg.vx), len(msg.vy)}
    if len(lengths) != 1 or min(lengths) < 2:
        raise ValueError(f'process role of {msg.robot!r}: x, y, vx, vy must have one equal length >= 2 '
                         f'(got {len(msg.x)}, {len(msg.y)}, {len(msg.vx)}, {len(msg.vy)})')
    if not (msg.dt > 0 and np.isfinite(msg.dt)):
        raise ValueError(f'process role of {msg.robot!r}: dt must be > 0 (got {msg.dt})')
    return np.column_stack([msg.x, msg.y, msg.vx, msg.vy]).astype(float)


def shared_role(msg: ProcessRole) -> SharedRole:
    """The message as a SharedRole; ValueError naming the field when it is malformed."""
    if not msg.robot:
        raise ValueError('process role: robot must be a non-empty name')
    states = trajectory_of(msg)
    if not np.isfinite(states).all():
        raise ValueError(f'process role of {msg.robot!r}: x, y, vx, vy must be finite')
    if not (np.isfinite(msg.radius) and msg.radius >= 0):
        raise ValueError(f'process role of {msg.robot!r}: radius must be finite and >= 0 (got {msg.radius})')
    if not np.isfinite(msg.start_time):
        raise ValueError(f'process role of {msg.robot!r}: start_time must be finite (got {msg.start_time})')
    return SharedRole(msg.robot, states, msg.dt * (len(states) - 1), msg.radius, msg.start_time)

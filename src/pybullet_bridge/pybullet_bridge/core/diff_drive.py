"""Velocity and acceleration limits of a differential-drive base (pure math)."""
from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class DiffDriveLimits:
    max_linear_velocity: float       # m/s
    max_angular_velocity: float      # rad/s
    max_linear_acceleration: float   # m/s^2
    max_angular_acceleration: float  # rad/s^2

    def __post_init__(self) -> None:
        for name, value in vars(self).items():
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f'{name}: must be a finite number > 0 (got {value})')


def _clamp(value: float, bound: float) -> float:
    return max(-bound, min(bound, value))


def limit_velocity(target: tuple[float, float], current: tuple[float, float],
                   limits: DiffDriveLimits, dt: float) -> tuple[float, float]:
    """Return the (linear, angular) velocity to apply for the next ``dt`` seconds.

    The target is clamped to the velocity limits, then the current velocity moves
    toward it by at most ``acceleration * dt`` per component. Linear and angular
    parts are limited independently, like the Pioneer and TurtleBot firmware do,
    so a saturated command may follow a slightly different arc than asked.
    """
    if not (math.isfinite(dt) and dt >= 0):
        raise ValueError(f'dt: must be a finite number >= 0 (got {dt})')
    if not all(math.isfinite(v) for v in (*target, *current)):
        raise ValueError(f'non-finite velocity (target {target}, current {current})')
    target_linear = _clamp(target[0], limits.max_linear_velocity)
    target_angular = _clamp(target[1], limits.max_angular_velocity)
    linear = current[0] + _clamp(target_linear - current[0], limits.max_linear_acceleration * dt)
    angular = current[1] + _clamp(target_angular - current[1], limits.max_angular_acceleration * dt)
    return linear, angular

"""How long an arm's motion segments take: a smooth (cubic) time law capped by the arm's limits."""
from __future__ import annotations

import numpy as np

#: Shortest planned segment (s): very short moves still ramp smoothly.
MIN_SEGMENT_DURATION = 0.2
#: The cubic time law's peak speed is 1.5 x its mean speed.
CUBIC_PEAK_FACTOR = 1.5


def cubic(tau: float) -> tuple[float, float]:
    """Smooth time law s(tau) = 3 tau^2 - 2 tau^3 and ds/dtau on [0, 1]."""
    tau = min(max(tau, 0.0), 1.0)
    return 3.0 * tau ** 2 - 2.0 * tau ** 3, 6.0 * tau * (1.0 - tau)


def joint_move_duration(start: np.ndarray, goal: np.ndarray, velocity_limits: np.ndarray) -> float:
    """Time for a joint-space move whose slowest joint peaks at its velocity limit."""
    slowest = float(np.max(np.abs(goal - start) / velocity_limits))
    return max(MIN_SEGMENT_DURATION, CUBIC_PEAK_FACTOR * slowest)


def linear_move_duration(start: np.ndarray, goal: np.ndarray, max_tool_speed: float) -> float:
    """Time for a straight tool move that peaks at ``max_tool_speed``."""
    distance = float(np.linalg.norm(np.asarray(goal) - np.asarray(start)))
    return max(MIN_SEGMENT_DURATION, CUBIC_PEAK_FACTOR * distance / max_tool_speed)

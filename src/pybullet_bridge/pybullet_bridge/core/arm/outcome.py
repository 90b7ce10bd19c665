"""How a pick-and-place task ended, and the message that says so.

A task that ran to its end is judged by where the object rests: inside the place region,
flat on its support (height within ``REST_HEIGHT_TOLERANCE``, tilt below
``UPRIGHT_TOLERANCE_DEG``) is PLACED; anything else EXECUTION_FAILED. A canceled task is
ABORTED; a failed motion or a slipped grasp (the simulated execution failure) EXECUTION_FAILED.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from .task import Outcome, PickPlaceTask

#: Result checks: the object must rest this close to its support height (m) and tilt less (deg).
REST_HEIGHT_TOLERANCE = 0.006
UPRIGHT_TOLERANCE_DEG = 10.0


@dataclass(frozen=True)
class Ending:
    """Why the task's motion stopped (the state machine's flags when it completed)."""

    canceled: bool
    cancel_reason: str
    put_back: bool
    failure: str                # '' when every segment converged


def tilt_deg(orientation_xyzw) -> float:
    """Angle (deg) between the object's nearest axis and the world vertical."""
    # The bottom row of the rotation matrix, computed as Bullet's getMatrixFromQuaternion does.
    x, y, z, w = orientation_xyzw
    s = 2.0 / (x * x + y * y + z * z + w * w)
    xs, ys, zs = x * s, y * s, z * s
    bottom_row = (x * zs - w * ys, y * zs + w * xs, 1.0 - (x * xs + y * ys))
    return math.degrees(math.acos(min(1.0, max(abs(v) for v in bottom_row))))


def judge_placement(task: PickPlaceTask, orientation_xyzw, support_height: float,
                    object_edge: float) -> tuple[Outcome, str]:
    """PLACED if the object rests flat inside the region, else EXECUTION_FAILED saying how it is off."""
    x, y, z = task.placed_position
    xmin, ymin, xmax, ymax = task.region
    tilt = tilt_deg(orientation_xyzw)
    resting_z = support_height + object_edge / 2.0
    where = f'({x:.3f}, {y:.3f}, {z:.3f})'
    if not (xmin <= x <= xmax and ymin <= y <= ymax):
        return Outcome.EXECUTION_FAILED, (f"'{task.object_name}' ended at {where}, outside place_region "
                                          f'{list(task.region)}')
    if abs(z - resting_z) > REST_HEIGHT_TOLERANCE or tilt > UPRIGHT_TOLERANCE_DEG:
        return Outcome.EXECUTION_FAILED, (f"'{task.object_name}' ended at {where} tilted {tilt:.0f} deg; "
                                          f'it does not rest flat at z {resting_z:.3f}')
    return Outcome.PLACED, f"'{task.object_name}' placed at {where}"


def task_outcome(task: PickPlaceTask, ending: Ending, orientation_xyzw, failure_probability: float,
                 support_height: float, object_edge: float) -> tuple[Outcome, str]:
    """The outcome and message of a task whose object now rests at ``task.placed_position``."""
    x, y, z = task.placed_position
    where = f'({x:.3f}, {y:.3f}, {z:.3f})'
    if ending.canceled:
        what = 'was put back; it rests at' if ending.put_back else 'was not grasped; it is at'
        trouble = f' (while going back: {ending.failure})' if ending.failure else ''
        return Outcome.ABORTED, f"{ending.cancel_reason}: '{task.object_name}' {what} {where}{trouble}"
    if ending.failure:
        return Outcome.EXECUTION_FAILED, f"{ending.failure}; '{task.object_name}' is at {where}"
    if task.slipped:
        return Outcome.EXECUTION_FAILED, (f"the grasp slipped (simulated execution failure, "
                                          f"failure_probability {failure_probability}); '{task.object_name}' "
                                          f'stayed at {where}')
    return judge_placement(task, orientation_xyzw, support_height, object_edge)

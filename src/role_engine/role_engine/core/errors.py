"""Errors raised by the role engine core, and the number checks that raise them."""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from collab_tools.core.errors import ConfigurationError
from collab_tools.core.settings import echo


class RoleEngineError(ConfigurationError):
    """Invalid input to the role engine core (a :class:`ConfigurationError`, so a ``ValueError``).

    The message starts with the name or dotted path of the offending value and says the
    allowed range, e.g. ``robot_type.radius: must be a finite number >= 0 (got -1.0)``.
    Configuration files are read with the shared field readers (:mod:`collab_tools.core.fields`,
    ``error=RoleEngineError``), so their errors are this class too.
    """


def check_real(value: Any, path: str, *, positive: bool = False, non_negative: bool = False) -> float:
    """``value`` as a finite float, else RoleEngineError naming ``path`` (and the bound it breaks)."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise RoleEngineError(f'{path}: must be a number (got {type(value).__name__} {echo(value)})')
    number = float(value)
    if not math.isfinite(number):
        raise RoleEngineError(f'{path}: must be finite (got {number})')
    if positive and number <= 0.0:
        raise RoleEngineError(f'{path}: must be > 0 (got {number})')
    if non_negative and number < 0.0:
        raise RoleEngineError(f'{path}: must be >= 0 (got {number})')
    return number


def check_count(value: Any, path: str, *, minimum: int) -> int:
    """``value`` as an int >= ``minimum``, else RoleEngineError naming ``path``."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise RoleEngineError(f'{path}: must be an integer (got {type(value).__name__} {echo(value)})')
    if value < minimum:
        raise RoleEngineError(f'{path}: must be >= {minimum} (got {value})')
    return int(value)

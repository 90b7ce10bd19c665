"""The value of an information instance: the fields each information type carries and their checks (no ROS).

The search only handles labels (F_R(robot_1, robot_2)); execution needs their values -- a
sensor report, a streamed INFORMATION message, an a-priori value.

Values (:data:`VALUE_FIELDS`, our choice -- the paper gives no units or frames): planar, SI units,
a mapping of field name -> float:

=========  ===========================================================================
F_G(X)     ``x``, ``y``: X's global position (m); optional ``yaw`` (rad), X's heading
F_R(X, Y)  ``x``, ``y``: X's position in Y's frame (x forward, y left); optional ``yaw``: X's
           heading relative to Y's (a fiducial that sees position only leaves it out)
F_B(X)     ``pressed``: 1 when X's bumper touches something, else 0
F_A(X)     ``min_range``: the shortest range X's laser measures (m)
F_F(X)     ``force``: the force X exerts along its heading (N)
F_T(X, Y)  ``torque``: the torque X exerts on Y about Y's centre (N m)
F_M        no fields (the map is a priori)
=========  ===========================================================================

A type the table does not name (a library may add types) takes any finite numbers (at most
:data:`MAX_FIELDS`). Sensor reports give a value as a mapping (:func:`check_value`); on the agent
channel it is a list of name/number pairs (``coalition_interfaces/NamedValue[] values`` of an
INFORMATION AgentMessage, :func:`check_value_fields`), each field at most once.
"""
from __future__ import annotations

import math
from typing import Any, Iterable, Mapping

from collab_tools.core.fields import type_name as describe_type

from .errors import RequestError


#: label -> (required fields, optional fields)
VALUE_FIELDS: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {
    'F_G': (('x', 'y'), ('yaw',)),
    'F_R': (('x', 'y'), ('yaw',)),
    'F_B': (('pressed',), ()),
    'F_A': (('min_range',), ()),
    'F_F': (('force',), ()),
    'F_T': (('torque',), ()),
    'F_M': ((), ()),
}

#: How many fields a value of an unlisted type may carry (a bound against oversized messages).
MAX_FIELDS = 16


def check_value(label: str, value: Any, path: str = 'values') -> dict[str, float]:
    """The value of an instance of type ``label``, given as a mapping of field name -> number
    (a sensor report), as a plain dict of floats; RequestError (a ValueError) naming the field
    otherwise."""
    if not isinstance(value, Mapping):
        raise RequestError(f'{path}: must be a mapping of field name -> number (got {describe_type(value)})')
    return _checked_fields(label, list(value.items()), path)


def check_value_fields(label: str, fields: Iterable[tuple[Any, Any]], path: str = 'values') -> dict[str, float]:
    """The value of an instance of type ``label``, given as (name, number) pairs in order (the
    wire form: AgentMessage ``values``, a list of NamedValue), as a plain dict of floats.

    Besides what :func:`check_value` checks, every field appears once: a mapping cannot repeat a
    key, a list can, and silently keeping one of two numbers would hide a sender's bug."""
    pairs = list(fields)
    seen: dict[str, int] = {}
    for index, (name, _) in enumerate(pairs):
        if not isinstance(name, str) or not name:
            raise RequestError(f'{path}[{index}].name: must be a non-empty field name (got {describe_type(name)} '
                               f'{name!r})')
        if name in seen:
            raise RequestError(f'{path}.{name}: given twice (at {path}[{seen[name]}] and {path}[{index}]; '
                               f'each field of a value appears once)')
        seen[name] = index
    return _checked_fields(label, pairs, path)


def _checked_fields(label: str, pairs: list[tuple[Any, Any]], path: str) -> dict[str, float]:
    """The checks both forms share: known field names for a listed type, finite numbers, the
    required fields present, at most MAX_FIELDS for an unlisted type. Errors read
    ``<path>.<field>: ...``."""
    fields = VALUE_FIELDS.get(label)
    if fields is None and len(pairs) > MAX_FIELDS:
        raise RequestError(f'{path}: at most {MAX_FIELDS} fields (got {len(pairs)})')
    checked: dict[str, float] = {}
    for name, number in pairs:
        if not isinstance(name, str) or not name:
            raise RequestError(f'{path}: field names must be non-empty strings (got {name!r})')
        if fields is not None and name not in fields[0] + fields[1]:
            raise RequestError(f"{path}.{name}: unknown field of a {label} value "
                               f"(allowed: {', '.join(fields[0] + fields[1]) or 'none'})")
        if isinstance(number, bool) or not isinstance(number, (int, float)) or not math.isfinite(number):
            raise RequestError(f'{path}.{name}: must be a finite number (got {describe_type(number)} {number!r})')
        checked[name] = float(number)
    if fields is not None:
        missing = [name for name in fields[0] if name not in checked]
        if missing:
            raise RequestError(f'{path}.{missing[0]}: missing required field of a {label} value')
    return checked


__all__ = ['MAX_FIELDS', 'VALUE_FIELDS', 'check_value', 'check_value_fields']

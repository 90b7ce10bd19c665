"""Node settings as plain data: each parameter's type, default, range and description, and the
check of a set of values, without ROS.

A node's settings are written once, in its package's core, as a :class:`SettingsSchema`::

    LEADER_SETTINGS = SettingsSchema(
        Setting('horizon', 3, 'rolling horizon T (stages)', low=0, high=6),
        Setting('camera_topic', 'camera/image', 'top-view camera', required=True),
        Setting('replan_period', 1.0, 'seconds between re-plans', low=0.0, low_open=True, dynamic=True),
    )
    values = LEADER_SETTINGS.validate({'horizon': 7})   # ConfigurationError: parameter horizon: ...

The ROS adapter (:class:`collab_tools.parameters.NodeParameters`) declares the same settings
as ROS parameters (type, range, description, read-only unless ``dynamic``), so ``ros2 param
describe`` shows them and a bad start value stops the node with exit code 2; unit tests check
the bad values against the schema directly, without starting a node.
"""
from __future__ import annotations

import math
import reprlib
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

from .errors import ConfigurationError

#: How far an error message echoes a value (a huge value must not flood a log or a response).
ECHO_LIMIT = 80

#: Kinds of values a ROS parameter can hold, named as in rcl_interfaces/ParameterType.
KINDS = ('bool', 'integer', 'double', 'string', 'bool_array', 'integer_array', 'double_array', 'string_array')

KIND_WORDS = {'bool': 'true or false', 'integer': 'an integer', 'double': 'a number', 'string': 'a string',
              'bool_array': 'a list of true/false', 'integer_array': 'a list of integers',
              'double_array': 'a list of numbers', 'string_array': 'a list of strings'}


_ECHO = reprlib.Repr()
_ECHO.maxlevel, _ECHO.maxstring, _ECHO.maxlong, _ECHO.maxother = 3, ECHO_LIMIT, 40, ECHO_LIMIT
for _name in ('maxtuple', 'maxlist', 'maxarray', 'maxdict', 'maxset', 'maxfrozenset', 'maxdeque'):
    setattr(_ECHO, _name, 8)


def echo(value: Any) -> str:
    """``repr(value)`` cut to ECHO_LIMIT characters, in bounded time: only the first elements and
    levels of a collection are looked at (a YAML alias bomb shares one list a billion times)."""
    if isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > 128:
        return f'<{value.bit_length()}-bit integer>'
    try:
        text = _ECHO.repr(value)
    except (ValueError, RecursionError, MemoryError):     # an unprintable value
        return f'<{type(value).__name__}>'
    return text if len(text) <= ECHO_LIMIT else text[:ECHO_LIMIT - 3] + '...'


def kind_of(default: Any) -> str:
    """The parameter kind a default value implies (an array needs one element to say its type)."""
    for python_type, kind in ((bool, 'bool'), (int, 'integer'), (float, 'double'), (str, 'string')):
        if isinstance(default, python_type):
            return kind
    if isinstance(default, (list, tuple)) and default:
        return kind_of(default[0]) + '_array'
    raise TypeError(f'cannot infer a parameter type from the default {default!r} '
                    '(use a non-empty list, e.g. [""] for a string array)')


def _is_kind(value: Any, kind: str) -> bool:
    if kind.endswith('_array'):
        return isinstance(value, (list, tuple)) and all(_is_kind(v, kind[:-6]) for v in value)
    if kind == 'bool':
        return isinstance(value, bool)
    if kind == 'integer':
        return isinstance(value, int) and not isinstance(value, bool)
    if kind == 'double':
        return isinstance(value, float)
    return isinstance(value, str)


@dataclass(frozen=True)
class Setting:
    """One parameter: default (its type), description and constraints.

    low/high: inclusive bounds unless low_open/high_open (each element for numeric arrays);
    choices: allowed strings; length: array length; required: the default (empty) is not a value;
    check(value) -> problem text or None, for what a range cannot say; dynamic: may change at run
    time (the node applies it), otherwise read-only after start.
    """
    name: str
    default: Any
    description: str
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False
    choices: Sequence[str] | None = None
    length: int | None = None
    required: bool = False
    check: Callable[[Any], str | None] | None = None
    dynamic: bool = False
    kind: str = field(default='', compare=False)

    def __post_init__(self):
        object.__setattr__(self, 'kind', self.kind or kind_of(self.default))
        if self.choices is not None:
            object.__setattr__(self, 'choices', tuple(self.choices))

    @property
    def numeric(self) -> bool:
        return self.kind in ('integer', 'double', 'integer_array', 'double_array')

    def constraints_text(self) -> str:
        """What is allowed beyond the type, in words (the descriptor's additional_constraints)."""
        parts = []
        if self.low is not None or self.high is not None:
            left = '(' if self.low_open else '['
            right = ')' if self.high_open else ']'
            low = '-inf' if self.low is None else f'{self.low:g}'
            high = 'inf' if self.high is None else f'{self.high:g}'
            parts.append(f'in {left}{low}, {high}{right}' + (' for each element' if self.kind.endswith('_array') else ''))
        if self.choices is not None:
            parts.append('one of: ' + ', '.join(self.choices))
        if self.length is not None:
            parts.append(f'exactly {self.length} elements')
        if self.required:
            parts.append('required (no default)')
        return '; '.join(parts)

    def coerce(self, value: Any) -> Any:
        """``value`` in this setting's type (an integer where a double belongs is that double, as a user
        means it), or ConfigurationError naming the expected type."""
        if isinstance(value, tuple):
            value = list(value)
        if self.kind == 'double' and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        elif self.kind == 'double_array' and isinstance(value, list) \
                and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
            value = [float(v) for v in value]
        if not _is_kind(value, self.kind):
            raise ConfigurationError(f'parameter {self.name}: must be {KIND_WORDS[self.kind]} (got {echo(value)})')
        return value

    def problem(self, value: Any) -> str | None:
        """Why ``value`` (of the right type) is not acceptable; None when it is."""
        if self.required and (value == '' or value is None or
                              (isinstance(value, (list, tuple)) and not [v for v in value if v != ''])):
            return 'required'
        numbers = list(value) if self.kind.endswith('_array') and self.numeric else (
            [value] if self.numeric else [])
        for number in numbers:
            if isinstance(number, float) and not math.isfinite(number):
                return f'must be finite (got {echo(value)})'
            if self.low is not None and (number <= self.low if self.low_open else number < self.low) or \
                    self.high is not None and (number >= self.high if self.high_open else number > self.high):
                return f'must be {self.constraints_text()} (got {echo(value)})'
        if self.choices is not None:
            for item in ([value] if isinstance(value, str) else list(value)):
                if item not in self.choices:
                    return f"must be one of {', '.join(self.choices)} (got {echo(item)})"
        if self.length is not None and len(value) != self.length:
            return f'must have exactly {self.length} elements (got {len(value)})'
        if self.check is not None:
            return self.check(value)
        return None

    def accept(self, value: Any) -> Any:
        """``value`` coerced and checked, or ConfigurationError ``parameter <name>: <problem>``."""
        value = self.coerce(value)
        problem = self.problem(value)
        if problem is not None:
            raise ConfigurationError(f'parameter {self.name}: {problem}')
        return value


class SettingsSchema:
    """The settings of one node, in declaration order."""

    #: Parameters every rclpy node has; a schema never declares them and ignores them in validate().
    ROS_OWNED = ('use_sim_time',)

    def __init__(self, *settings: Setting):
        names = [s.name for s in settings]
        duplicates = sorted({n for n in names if names.count(n) > 1})
        if duplicates:
            raise ValueError(f'settings declared twice: {", ".join(duplicates)}')
        self._settings = {s.name: s for s in settings}

    def __iter__(self):
        return iter(self._settings.values())

    def __len__(self) -> int:
        return len(self._settings)

    def __contains__(self, name: str) -> bool:
        return name in self._settings

    def __getitem__(self, name: str) -> Setting:
        return self._settings[name]

    @property
    def names(self) -> list[str]:
        return list(self._settings)

    def extended(self, *settings: Setting) -> 'SettingsSchema':
        """This schema plus more settings (e.g. a node's own beside a shared group)."""
        return SettingsSchema(*self._settings.values(), *settings)

    def replaced(self, name: str, **changes: Any) -> 'SettingsSchema':
        """This schema with setting ``name`` changed (e.g. a ``check`` only the node can do, such as
        resolving a topic name in its namespace)."""
        return SettingsSchema(*(replace(s, **changes) if s.name == name else s for s in self._settings.values()))

    def defaults(self) -> dict[str, Any]:
        return {name: setting.default for name, setting in self._settings.items()}

    def validate(self, values: Mapping[str, Any], *, ignore: Iterable[str] = ()) -> dict[str, Any]:
        """Every setting's value (given or default), checked: what a node would start with.

        An unknown name is an error (a typo in a parameters file must not pass unnoticed), except
        the ROS-owned ones and ``ignore``.
        """
        skip = set(self.ROS_OWNED) | set(ignore)
        unknown = sorted(set(values) - set(self._settings) - skip)
        if unknown:
            raise ConfigurationError(f'parameter {unknown[0]}: unknown (known: {", ".join(self._settings)})')
        result = {}
        for name, setting in self._settings.items():
            result[name] = setting.accept(values[name]) if name in values else setting.accept(setting.default)
        return result

"""Validating readers for the fields of YAML files, dicts and parameter values: the one vocabulary
every package's core uses (scenarios, task files, team files, experiment configs).

Every reader takes the dotted path of the value it checks and raises an error whose message
starts with that path, e.g. ``mobile_robots[1].max_linear_velocity: must be > 0 (got -1.0)``.
The error class is the caller's (``error=``, default :class:`ConfigurationError`), so each package
keeps its own exception type (``ScenarioError``, ``ConfigError``, ...) while the wording is shared.
A :class:`Fields` object reads one mapping and rejects keys it does not know, so typos never pass.

Pure Python + PyYAML: any core may import this without pulling in a simulator or ROS.
"""
from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping, TypeVar

from . import input_files
from .errors import ConfigurationError
from .settings import echo

#: Names of robots, objects, sensors, tasks: they become ROS namespaces and frame ids.
NAME_PATTERN = re.compile(r'[A-Za-z][A-Za-z0-9_]*\Z')

#: Sentinel meaning "no default: the field is required".
REQUIRED: Any = object()

ErrorType = type[ValueError]
_Loaded = TypeVar('_Loaded')


def join_path(path: str, key: str | int) -> str:
    """The dotted path of ``key`` (a mapping key or list index) below ``path``."""
    if isinstance(key, int):
        return f'{path}[{key}]'
    return f'{path}.{key}' if path else str(key)


def fail(path: str, message: str, error: ErrorType = ConfigurationError) -> ValueError:
    """The error for ``path``; callers ``raise fail(...)`` so the flow stays visible."""
    return error(f'{path}: {message}')


def type_name(value: Any) -> str:
    """The YAML name of a value's type, for error messages."""
    names = {type(None): 'null', bool: 'bool', int: 'int', float: 'float', str: 'str',
             list: 'list', tuple: 'list', dict: 'mapping'}
    return names.get(type(value), type(value).__name__)


# --- files and text ----------------------------------------------------------------------------

def read_yaml_file(path: str | Path, what: str = 'file', error: ErrorType = ConfigurationError) -> Any:
    """The parsed content of a YAML file; ``<what> '<path>': ...`` when it is missing, no regular
    file, too big, not UTF-8, not YAML, beyond the YAML bounds or empty (:mod:`.input_files`)."""
    return input_files.read_yaml_file(path, what, error)


def parse_yaml_text(text: Any, error: ErrorType = ConfigurationError) -> Any:
    """A YAML document given as text (e.g. a string parameter), within the same bounds as a file;
    the caller names where it came from."""
    if not isinstance(text, str):
        raise error(f'must be YAML text (got {type_name(text)})')
    return input_files.load_yaml_text(text, error)


def load_config_file(path: str | Path, read: Callable[[Any], _Loaded],
                     error: ErrorType = ConfigurationError, what: str = 'file') -> _Loaded:
    """``read(data)`` of a YAML file; every error of ``read`` is prefixed with the file's path."""
    data = read_yaml_file(path, what, error)
    try:
        return read(data)
    except error as err:
        message = str(err)
        shown = input_files.shown_path(path)
        raise error(message if message.startswith(shown) else f'{shown}: {message}') from None


# --- values ------------------------------------------------------------------------------------

def require_mapping(value: Any, path: str, error: ErrorType = ConfigurationError) -> Mapping[str, Any]:
    if not isinstance(value, Mapping):
        raise fail(path or '<file>', f'must be a mapping (got {type_name(value)})', error)
    return value


def require_list(value: Any, path: str, error: ErrorType = ConfigurationError) -> list:
    if not isinstance(value, (list, tuple)):
        raise fail(path, f'must be a list (got {type_name(value)})', error)
    return list(value)


def check_number(value: Any, path: str, *, gt: float | None = None, ge: float | None = None,
                 lt: float | None = None, le: float | None = None,
                 error: ErrorType = ConfigurationError) -> float:
    """``value`` as a finite float within the given bounds."""
    # bool is an int subclass; `true` where a number belongs is always a typo.
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise fail(path, f'must be a number (got {type_name(value)} {echo(value)})', error)
    number = float(value)
    if not math.isfinite(number):
        raise fail(path, f'must be finite (got {echo(number)})', error)
    if gt is not None and not number > gt:
        raise fail(path, f'must be > {gt} (got {echo(number)})', error)
    if ge is not None and not number >= ge:
        raise fail(path, f'must be >= {ge} (got {echo(number)})', error)
    if lt is not None and not number < lt:
        raise fail(path, f'must be < {lt} (got {echo(number)})', error)
    if le is not None and not number <= le:
        raise fail(path, f'must be <= {le} (got {echo(number)})', error)
    return number


def check_int(value: Any, path: str, *, ge: int | None = None, le: int | None = None,
              error: ErrorType = ConfigurationError) -> int:
    """``value`` as an int within ``[ge, le]``."""
    if isinstance(value, bool) or not isinstance(value, int):
        raise fail(path, f'must be an integer (got {type_name(value)} {echo(value)})', error)
    if ge is not None and value < ge:
        raise fail(path, f'must be >= {ge} (got {echo(value)})', error)
    if le is not None and value > le:
        raise fail(path, f'must be <= {le} (got {echo(value)})', error)
    return int(value)


def check_vector(value: Any, path: str, length: int, *, error: ErrorType = ConfigurationError,
                 **bounds: float | None) -> tuple[float, ...]:
    """``value`` as a tuple of ``length`` floats, each within ``bounds``."""
    if not isinstance(value, (list, tuple)) or len(value) != length:
        raise fail(path, f'must be a list of {length} numbers (got {echo(value)})', error)
    return tuple(check_number(item, join_path(path, i), error=error, **bounds) for i, item in enumerate(value))


def check_color(value: Any, path: str, error: ErrorType = ConfigurationError) -> tuple[float, float, float]:
    """An ``[r, g, b]`` colour with each channel in ``[0, 1]``."""
    return check_vector(value, path, 3, ge=0.0, le=1.0, error=error)  # type: ignore[return-value]


def check_name(value: Any, path: str, error: ErrorType = ConfigurationError) -> str:
    """A name matching :data:`NAME_PATTERN`."""
    if not isinstance(value, str):
        raise fail(path, f'must be a string (got {type_name(value)} {echo(value)})', error)
    if not NAME_PATTERN.match(value):
        raise fail(path, f"invalid name {echo(value)} (must match [A-Za-z][A-Za-z0-9_]*)", error)
    return value


class Fields:
    """Reads the fields of one mapping, rejecting keys outside ``allowed``.

    Example::

        fields = Fields(data, 'camera', allowed=('width', 'height'), error=ScenarioError)
        width = fields.integer('width', ge=16, le=2048)
    """

    def __init__(self, data: Any, path: str, allowed: Iterable[str], error: ErrorType = ConfigurationError):
        self.path = path
        self.allowed = tuple(allowed)
        self.error = error
        self.data = require_mapping(data, path, error)
        for key in self.data:
            if key not in self.allowed:
                raise fail(join_path(path, echo(key)[1:-1] if isinstance(key, str) else echo(key)), f"unknown field (allowed: {', '.join(self.allowed)})", error)

    def path_of(self, key: str | int) -> str:
        return join_path(self.path, key)

    def fail(self, key: str, message: str) -> ValueError:
        """The error for field ``key`` of this mapping."""
        return fail(self.path_of(key), message, self.error)

    def has(self, key: str) -> bool:
        return key in self.data

    def raw(self, key: str, default: Any = REQUIRED) -> Any:
        """The unvalidated value, the default, or an error if required and missing."""
        if key in self.data:
            return self.data[key]
        if default is REQUIRED:
            raise self.fail(key, 'missing required field')
        return default

    def number(self, key: str, default: Any = REQUIRED, **bounds: float | None) -> float:
        if key not in self.data and default is not REQUIRED:
            return default
        return check_number(self.raw(key), self.path_of(key), error=self.error, **bounds)

    def integer(self, key: str, default: Any = REQUIRED, **bounds: int | None) -> int:
        if key not in self.data and default is not REQUIRED:
            return default
        return check_int(self.raw(key), self.path_of(key), error=self.error, **bounds)

    def boolean(self, key: str, default: Any = REQUIRED) -> bool:
        if key not in self.data and default is not REQUIRED:
            return default
        value = self.raw(key)
        if not isinstance(value, bool):
            raise self.fail(key, f'must be true or false (got {type_name(value)} {echo(value)})')
        return value

    def string(self, key: str, default: Any = REQUIRED, *, allow_empty: bool = False) -> str:
        if key not in self.data and default is not REQUIRED:
            return default
        value = self.raw(key)
        if not isinstance(value, str) or (not value and not allow_empty):
            kind = 'a string' if allow_empty else 'a non-empty string'
            raise self.fail(key, f'must be {kind} (got {type_name(value)} {echo(value)})')
        return value

    def choice(self, key: str, choices: Iterable[str], default: Any = REQUIRED) -> str:
        if key not in self.data and default is not REQUIRED:
            return default
        allowed = tuple(choices)
        value = self.raw(key)
        if value not in allowed:
            raise self.fail(key, f"must be one of {', '.join(allowed)} (got {echo(value)})")
        return value

    def name(self, key: str = 'name', default: Any = REQUIRED) -> str:
        if key not in self.data and default is not REQUIRED:
            return default
        return check_name(self.raw(key), self.path_of(key), self.error)

    def vector(self, key: str, length: int, default: Any = REQUIRED, **bounds: float | None) -> tuple[float, ...]:
        if key not in self.data and default is not REQUIRED:
            return default
        return check_vector(self.raw(key), self.path_of(key), length, error=self.error, **bounds)

    def color(self, key: str = 'color', default: Any = REQUIRED) -> tuple[float, float, float]:
        if key not in self.data and default is not REQUIRED:
            return default
        return check_color(self.raw(key), self.path_of(key), self.error)

    def mapping(self, key: str, default: Any = REQUIRED) -> Mapping[str, Any]:
        if key not in self.data and default is not REQUIRED:
            return default
        return require_mapping(self.raw(key), self.path_of(key), self.error)

    def items(self, key: str, default: Any = REQUIRED) -> list[tuple[str, Any]]:
        """(dotted path, value) of each element of the list field ``key``."""
        if key not in self.data and default is not REQUIRED:
            return default
        path = self.path_of(key)
        return [(join_path(path, i), item) for i, item in enumerate(require_list(self.raw(key), path, self.error))]

    def entries(self, key: str, default: Any = REQUIRED) -> list[tuple[str, str, Any]]:
        """(dotted path, name, value) of each entry of the mapping field ``key`` (names checked)."""
        if key not in self.data and default is not REQUIRED:
            return default
        path = self.path_of(key)
        mapping = require_mapping(self.raw(key), path, self.error)
        return [(join_path(path, str(name)), check_name(name, join_path(path, str(name)), self.error), value)
                for name, value in mapping.items()]

    def sub(self, key: str, allowed: Iterable[str], default: Any = REQUIRED) -> 'Fields':
        """The :class:`Fields` of the nested mapping ``key`` (an empty one when absent with a default)."""
        if key not in self.data and default is not REQUIRED:
            return Fields(default if default is not None else {}, self.path_of(key), allowed, self.error)
        return Fields(self.raw(key), self.path_of(key), allowed, self.error)

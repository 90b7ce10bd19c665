"""Validating readers for scenario fields.

Every reader takes the dotted path of the value it checks and raises
:class:`ScenarioError` with a message starting with that path. Section parsers
(mobile robots, obstacles, future kinds) use :class:`Fields` so that all of them
report mistakes the same way and reject unknown keys.
"""
from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any, Iterable, Mapping

import yaml

from .errors import ScenarioError

#: Scene names become ROS namespaces and frame ids, hence the strict pattern.
NAME_PATTERN = re.compile(r'[A-Za-z][A-Za-z0-9_]*\Z')

#: Sentinel meaning "no default: the field is required".
REQUIRED: Any = object()


def join_path(path: str, key: str | int) -> str:
    """Return the dotted path of ``key`` (a mapping key or list index) below ``path``."""
    if isinstance(key, int):
        return f'{path}[{key}]'
    return f'{path}.{key}' if path else str(key)


def fail(path: str, message: str) -> ScenarioError:
    """Build the error for ``path``; callers ``raise fail(...)`` so flow stays visible."""
    return ScenarioError(f'{path}: {message}')


def read_yaml_file(path: str | Path, what: str = 'file') -> Any:
    """The parsed content of a YAML file; ScenarioError "<what> '<path>': ..." when it is missing,
    unreadable, not YAML or empty."""
    path = Path(path)
    where = f"{what} '{path}'"
    if not path.exists():
        raise ScenarioError(f'{where}: does not exist')
    try:
        text = path.read_text(encoding='utf-8')
    except OSError as err:
        raise ScenarioError(f'{where}: cannot read ({err.strerror or err})') from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as err:
        raise ScenarioError(f'{where}: invalid YAML ({err})') from None
    if data is None:
        raise ScenarioError(f'{where}: file is empty')
    return data


def type_name(value: Any) -> str:
    """Human name of a YAML value's type, for error messages."""
    names = {type(None): 'null', bool: 'bool', int: 'int', float: 'float', str: 'str',
             list: 'list', tuple: 'list', dict: 'mapping'}
    return names.get(type(value), type(value).__name__)


def require_mapping(value: Any, path: str) -> Mapping[str, Any]:
    if not isinstance(value, Mapping):
        raise fail(path, f'must be a mapping (got {type_name(value)})')
    return value


def require_list(value: Any, path: str) -> list:
    if not isinstance(value, (list, tuple)):
        raise fail(path, f'must be a list (got {type_name(value)})')
    return list(value)


def check_number(value: Any, path: str, *, gt: float | None = None, ge: float | None = None,
                 lt: float | None = None, le: float | None = None) -> float:
    """Return ``value`` as a finite float within the given bounds."""
    # bool is an int subclass; `true` where a number belongs is always a typo.
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise fail(path, f'must be a number (got {type_name(value)} {value!r})')
    number = float(value)
    if not math.isfinite(number):
        raise fail(path, f'must be finite (got {number})')
    if gt is not None and not number > gt:
        raise fail(path, f'must be > {gt} (got {number})')
    if ge is not None and not number >= ge:
        raise fail(path, f'must be >= {ge} (got {number})')
    if lt is not None and not number < lt:
        raise fail(path, f'must be < {lt} (got {number})')
    if le is not None and not number <= le:
        raise fail(path, f'must be <= {le} (got {number})')
    return number


def check_int(value: Any, path: str, *, ge: int | None = None, le: int | None = None) -> int:
    """Return ``value`` as an int within ``[ge, le]``."""
    if isinstance(value, bool) or not isinstance(value, int):
        raise fail(path, f'must be an integer (got {type_name(value)} {value!r})')
    if ge is not None and value < ge:
        raise fail(path, f'must be >= {ge} (got {value})')
    if le is not None and value > le:
        raise fail(path, f'must be <= {le} (got {value})')
    return int(value)


def check_vector(value: Any, path: str, length: int, **bounds: float | None) -> tuple[float, ...]:
    """Return ``value`` as a tuple of ``length`` floats, each within ``bounds``."""
    if not isinstance(value, (list, tuple)) or len(value) != length:
        raise fail(path, f'must be a list of {length} numbers (got {value!r})')
    return tuple(check_number(item, join_path(path, i), **bounds) for i, item in enumerate(value))


def check_color(value: Any, path: str) -> tuple[float, float, float]:
    """Return an ``[r, g, b]`` colour with each channel in ``[0, 1]``."""
    return check_vector(value, path, 3, ge=0.0, le=1.0)  # type: ignore[return-value]


def check_name(value: Any, path: str) -> str:
    """Return a scene name matching :data:`NAME_PATTERN`."""
    if not isinstance(value, str):
        raise fail(path, f'must be a string (got {type_name(value)} {value!r})')
    if not NAME_PATTERN.match(value):
        raise fail(path, f"invalid name '{value}' (must match [A-Za-z][A-Za-z0-9_]*)")
    return value


class Fields:
    """Reads the fields of one mapping, rejecting keys outside ``allowed``.

    Example::

        fields = Fields(data, 'camera', allowed=('width', 'height'))
        width = fields.integer('width', ge=16, le=2048)
    """

    def __init__(self, data: Any, path: str, allowed: Iterable[str]):
        self.path = path
        self.allowed = tuple(allowed)
        self.data = require_mapping(data, path)
        for key in self.data:
            if key not in self.allowed:
                raise fail(join_path(path, str(key)),
                           f"unknown field (allowed: {', '.join(self.allowed)})")

    def path_of(self, key: str) -> str:
        return join_path(self.path, key)

    def has(self, key: str) -> bool:
        return key in self.data

    def raw(self, key: str, default: Any = REQUIRED) -> Any:
        """Return the unvalidated value, the default, or raise if required and missing."""
        if key in self.data:
            return self.data[key]
        if default is REQUIRED:
            raise fail(self.path_of(key), 'missing required field')
        return default

    def number(self, key: str, default: Any = REQUIRED, **bounds: float | None) -> float:
        if key not in self.data and default is not REQUIRED:
            return default
        return check_number(self.raw(key), self.path_of(key), **bounds)

    def integer(self, key: str, default: Any = REQUIRED, **bounds: int | None) -> int:
        if key not in self.data and default is not REQUIRED:
            return default
        return check_int(self.raw(key), self.path_of(key), **bounds)

    def string(self, key: str, default: Any = REQUIRED) -> str:
        if key not in self.data and default is not REQUIRED:
            return default
        value = self.raw(key)
        if not isinstance(value, str) or not value:
            raise fail(self.path_of(key), f'must be a non-empty string (got {type_name(value)} {value!r})')
        return value

    def name(self, key: str = 'name', default: Any = REQUIRED) -> str:
        if key not in self.data and default is not REQUIRED:
            return default
        return check_name(self.raw(key), self.path_of(key))

    def vector(self, key: str, length: int, default: Any = REQUIRED,
               **bounds: float | None) -> tuple[float, ...]:
        if key not in self.data and default is not REQUIRED:
            return default
        return check_vector(self.raw(key), self.path_of(key), length, **bounds)

    def color(self, key: str = 'color', default: Any = REQUIRED) -> tuple[float, float, float]:
        if key not in self.data and default is not REQUIRED:
            return default
        return check_color(self.raw(key), self.path_of(key))

"""Readers for the fields of the coalition YAML files.

Each reader takes the dotted path of the value it checks and raises
:class:`~coalition_agents.core.errors.ConfigError` whose message starts with that path.
The style follows ``pybullet_bridge.core.fields``; it is not imported from there because
that package's import pulls in pybullet, which the coalition reasoner must not depend on.
"""
from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping, TypeVar

import yaml

from .errors import ConfigError

#: Names of robots, objects, sensors, schemas and tasks (they become ROS names later).
NAME_PATTERN = re.compile(r'[A-Za-z][A-Za-z0-9_]*\Z')

_MISSING: Any = object()
_Loaded = TypeVar('_Loaded')


def field_path(path: str, key: str | int) -> str:
    """Dotted path of ``key`` (mapping key or list index) below ``path``."""
    if isinstance(key, int):
        return f'{path}[{key}]'
    return f'{path}.{key}' if path else str(key)


def describe_type(value: Any) -> str:
    """YAML-ish name of a value's type, for error messages."""
    names = {type(None): 'null', bool: 'bool', int: 'int', float: 'float', str: 'str',
             list: 'list', tuple: 'list', dict: 'mapping'}
    return names.get(type(value), type(value).__name__)


def load_yaml_file(path: str | Path) -> Any:
    """Parse a YAML file; a missing file or a syntax error becomes a :class:`ConfigError`."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise ConfigError(f'{path}: cannot read file ({exc.strerror or exc})') from None
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ConfigError(f'{path}: invalid YAML ({exc})') from None


def parse_yaml_text(text: str) -> Any:
    """Parse a YAML document given as text (e.g. a string parameter); a syntax error becomes a
    :class:`ConfigError` (the caller names where the text came from)."""
    if not isinstance(text, str):
        raise ConfigError(f'must be YAML text (got {describe_type(text)})')
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ConfigError(f'invalid YAML ({exc})') from None


def load_config_file(path: str | Path, read: Callable[[Any], _Loaded]) -> _Loaded:
    """Parse a YAML file with ``read`` (data -> object); every error names the file first."""
    try:
        return read(load_yaml_file(path))
    except ConfigError as exc:
        message = str(exc)
        raise ConfigError(message if message.startswith(str(path)) else f'{path}: {message}') from None


def as_list(value: Any, path: str) -> list:
    if not isinstance(value, (list, tuple)):
        raise ConfigError(f'{path}: must be a list (got {describe_type(value)})')
    return list(value)


def as_mapping(value: Any, path: str) -> Mapping[str, Any]:
    if not isinstance(value, Mapping):
        raise ConfigError(f'{path}: must be a mapping (got {describe_type(value)})')
    return value


def as_name(value: Any, path: str) -> str:
    if not isinstance(value, str) or not NAME_PATTERN.match(value):
        raise ConfigError(f'{path}: must be a name matching [A-Za-z][A-Za-z0-9_]* (got {value!r})')
    return value


def as_number(value: Any, path: str, *, ge: float | None = None, gt: float | None = None) -> float:
    # bool is an int subclass; `true` where a number belongs is a typo.
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ConfigError(f'{path}: must be a number (got {describe_type(value)} {value!r})')
    number = float(value)
    if not math.isfinite(number):
        raise ConfigError(f'{path}: must be finite (got {number})')
    if ge is not None and number < ge:
        raise ConfigError(f'{path}: must be >= {ge} (got {number})')
    if gt is not None and number <= gt:
        raise ConfigError(f'{path}: must be > {gt} (got {number})')
    return number


class Section:
    """The fields of one YAML mapping; keys outside ``allowed`` are errors (typos never pass)."""

    def __init__(self, data: Any, path: str, allowed: Iterable[str]):
        self.path = path
        self.allowed = tuple(allowed)
        self.data = as_mapping(data, path or '<file>')
        for key in self.data:
            if key not in self.allowed:
                raise ConfigError(f'{field_path(path, str(key))}: unknown field '
                                  f'(allowed: {", ".join(self.allowed)})')

    def at(self, key: str) -> str:
        return field_path(self.path, key)

    def get(self, key: str, default: Any = _MISSING) -> Any:
        if key in self.data:
            return self.data[key]
        if default is _MISSING:
            raise ConfigError(f'{self.at(key)}: missing required field')
        return default

    def number(self, key: str, default: Any = _MISSING, **bounds: float) -> float:
        if key not in self.data and default is not _MISSING:
            return default
        return as_number(self.get(key), self.at(key), **bounds)

    def text(self, key: str, default: Any = _MISSING) -> str:
        if key not in self.data and default is not _MISSING:
            return default
        value = self.get(key)
        if not isinstance(value, str):
            raise ConfigError(f'{self.at(key)}: must be a string (got {describe_type(value)} {value!r})')
        return value

    def name(self, key: str, default: Any = _MISSING) -> str:
        if key not in self.data and default is not _MISSING:
            return default
        return as_name(self.get(key), self.at(key))

    def items(self, key: str, default: Any = _MISSING) -> list[tuple[str, Any]]:
        """(dotted path, value) of each element of the list field ``key``."""
        if key not in self.data and default is not _MISSING:
            return default
        path = self.at(key)
        return [(field_path(path, i), item) for i, item in enumerate(as_list(self.get(key), path))]

    def entries(self, key: str, default: Any = _MISSING) -> list[tuple[str, str, Any]]:
        """(dotted path, name, value) of each entry of the mapping field ``key`` (names checked)."""
        if key not in self.data and default is not _MISSING:
            return default
        path = self.at(key)
        mapping = as_mapping(self.get(key), path)
        return [(field_path(path, str(name)), as_name(name, field_path(path, str(name))), value)
                for name, value in mapping.items()]

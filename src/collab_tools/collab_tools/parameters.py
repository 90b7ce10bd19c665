"""Declared ROS parameters that are either applied or refused, never silently ignored.

Every node declares its parameters through :class:`NodeParameters`::

    self.params = NodeParameters(self)
    self.params.declare('real_time_factor', 1.0, 'simulated s per wall s; 0 = as fast as possible',
                        low=0.0, high=1000.0, on_change=self._set_real_time_factor)
    self.params.declare('scenario', '', 'path to the scenario YAML', required=True)
    rate = self.params['real_time_factor']

* The descriptor carries the type (from the default), the description, the numeric range
  (``FloatingPointRange`` / ``IntegerRange``, so ``ros2 param describe`` shows it and rclpy
  refuses values outside it) and, for what a ROS range cannot say (an open bound, a list of
  choices, a length), ``additional_constraints`` text that :meth:`declare` and the set callback
  enforce.
* A parameter with ``on_change`` is *dynamic*: a ``set_parameters`` call validates the new value
  and then calls ``on_change(value)``, which must make the node behave accordingly. Every other
  parameter is declared ``read_only``, so rclpy refuses a set with "Trying to set a read-only
  parameter" -- the node never reports success for a value it would ignore.
* A start-up value that breaks a constraint raises :class:`ConfigurationError` naming the
  parameter (``node_support.run`` turns it, and rclpy's own type/range exceptions, into exit 2).
* An integer given for a double parameter at start-up (``rate: 0`` in YAML, ``-p rate:=1``) is
  taken as that double, as a user means it; at run time rclpy's own type check applies.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, ParameterType, \
    SetParametersResult
from rclpy.node import Node
from rclpy.parameter import Parameter

from .node_support import ConfigurationError

#: How far an error message echoes a value (a huge value must not flood a log or a response).
ECHO_LIMIT = 80


def echo(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= ECHO_LIMIT else text[:ECHO_LIMIT - 3] + '...'


def _parameter_type(default: Any) -> int:
    if isinstance(default, bool):
        return ParameterType.PARAMETER_BOOL
    if isinstance(default, int):
        return ParameterType.PARAMETER_INTEGER
    if isinstance(default, float):
        return ParameterType.PARAMETER_DOUBLE
    if isinstance(default, str):
        return ParameterType.PARAMETER_STRING
    if isinstance(default, (list, tuple)) and default:
        first = default[0]
        if isinstance(first, bool):
            return ParameterType.PARAMETER_BOOL_ARRAY
        if isinstance(first, int):
            return ParameterType.PARAMETER_INTEGER_ARRAY
        if isinstance(first, float):
            return ParameterType.PARAMETER_DOUBLE_ARRAY
        if isinstance(first, str):
            return ParameterType.PARAMETER_STRING_ARRAY
    raise TypeError(f'cannot infer a parameter type from the default {default!r} '
                    '(use a non-empty list, e.g. [""] for a string array)')


_TYPE_WORDS = {
    ParameterType.PARAMETER_BOOL: 'true or false', ParameterType.PARAMETER_INTEGER: 'an integer',
    ParameterType.PARAMETER_DOUBLE: 'a number', ParameterType.PARAMETER_STRING: 'a string',
    ParameterType.PARAMETER_BOOL_ARRAY: 'a list of true/false', ParameterType.PARAMETER_INTEGER_ARRAY:
    'a list of integers', ParameterType.PARAMETER_DOUBLE_ARRAY: 'a list of numbers',
    ParameterType.PARAMETER_STRING_ARRAY: 'a list of strings'}


class _Spec:
    """One declared parameter: its constraints beyond the descriptor's range, and its applier."""

    def __init__(self, name: str, type_: int, *, low, high, low_open: bool, high_open: bool,
                 choices: Sequence[str] | None, length: int | None, required: bool,
                 check: Callable[[Any], str | None] | None, on_change: Callable[[Any], None] | None):
        self.name = name
        self.type = type_
        self.low, self.high, self.low_open, self.high_open = low, high, low_open, high_open
        self.choices = tuple(choices) if choices is not None else None
        self.length = length
        self.required = required
        self.check = check
        self.on_change = on_change

    def constraints_text(self) -> str:
        parts = []
        if self.low is not None or self.high is not None:
            left = '(' if self.low_open else '['
            right = ')' if self.high_open else ']'
            low = '-inf' if self.low is None else f'{self.low:g}'
            high = 'inf' if self.high is None else f'{self.high:g}'
            parts.append(f'in {left}{low}, {high}{right}' + (' for each element' if self._is_array() else ''))
        if self.choices is not None:
            parts.append('one of: ' + ', '.join(self.choices))
        if self.length is not None:
            parts.append(f'exactly {self.length} elements')
        if self.required:
            parts.append('required (no default)')
        return '; '.join(parts)

    def _is_array(self) -> bool:
        return self.type in (ParameterType.PARAMETER_DOUBLE_ARRAY, ParameterType.PARAMETER_INTEGER_ARRAY)

    def problem(self, value: Any) -> str | None:
        """Why `value` is not acceptable (None when it is)."""
        if self.required and (value == '' or value is None or
                              (isinstance(value, (list, tuple)) and not [v for v in value if v != ''])):
            return 'required'
        numbers = list(value) if self._is_array() else (
            [value] if self.type in (ParameterType.PARAMETER_DOUBLE, ParameterType.PARAMETER_INTEGER) else [])
        for number in numbers:
            if isinstance(number, float) and not math.isfinite(number):
                return f'must be finite (got {echo(value)})'
            if self.low is not None and (number <= self.low if self.low_open else number < self.low) or \
                    self.high is not None and (number >= self.high if self.high_open else number > self.high):
                return f'must be {self.constraints_text()} (got {echo(value)})'
        if self.choices is not None:
            values = [value] if isinstance(value, str) else list(value)
            for item in values:
                if item not in self.choices:
                    return f"must be one of {', '.join(self.choices)} (got {echo(item)})"
        if self.length is not None and len(value) != self.length:
            return f'must have exactly {self.length} elements (got {len(value)})'
        if self.check is not None:
            return self.check(value)
        return None


class NodeParameters:
    """The declared parameters of one node; see the module docstring."""

    def __init__(self, node: Node):
        self._node = node
        self._specs: dict[str, _Spec] = {}
        self._declaring = False
        node.add_on_set_parameters_callback(self._on_set)

    # --- declaring ---------------------------------------------------------------------------
    def declare(self, name: str, default: Any, description: str, *,
                low: float | None = None, high: float | None = None,
                low_open: bool = False, high_open: bool = False,
                choices: Sequence[str] | None = None, length: int | None = None,
                required: bool = False, check: Callable[[Any], str | None] | None = None,
                on_change: Callable[[Any], None] | None = None) -> Any:
        """Declare `name` and return its start-up value (ConfigurationError if it breaks a constraint).

        low/high: inclusive bounds unless low_open/high_open (each element for numeric arrays);
        choices: allowed strings; length: array length; check(value) -> problem text or None;
        on_change(value): makes the parameter dynamic (applied on set), else it is read-only.
        """
        type_ = _parameter_type(default)
        spec = _Spec(name, type_, low=low, high=high, low_open=low_open, high_open=high_open, choices=choices,
                     length=length, required=required, check=check, on_change=on_change)
        descriptor = ParameterDescriptor(name=name, type=type_, description=description,
                                         additional_constraints=spec.constraints_text(),
                                         read_only=on_change is None)
        if low is not None or high is not None:
            if type_ in (ParameterType.PARAMETER_INTEGER, ParameterType.PARAMETER_INTEGER_ARRAY):
                from_value = int(math.ceil(low)) if low is not None else -2**63
                to_value = int(math.floor(high)) if high is not None else 2**63 - 1
                descriptor.integer_range = [IntegerRange(from_value=from_value, to_value=to_value, step=0)]
            elif type_ in (ParameterType.PARAMETER_DOUBLE, ParameterType.PARAMETER_DOUBLE_ARRAY):
                descriptor.floating_point_range = [FloatingPointRange(
                    from_value=float(low) if low is not None else -math.inf,
                    to_value=float(high) if high is not None else math.inf, step=0.0)]
        self._coerce_integer_override(name, type_)
        self._check_override(spec)
        self._specs[name] = spec
        self._declaring = True
        try:
            self._node.declare_parameter(name, default, descriptor)
        finally:
            self._declaring = False
        value = self[name]
        problem = spec.problem(value)
        if problem is not None:
            raise ConfigurationError(f'parameter {name}: {problem}')
        return value

    def _coerce_integer_override(self, name: str, type_: int) -> None:
        # rclpy keeps the start-up overrides (params files, -p) in _parameter_overrides; an integer
        # for a double (YAML `0`, `-p rate:=1`) is what the user meant, so it is taken as a double.
        overrides = getattr(self._node, '_parameter_overrides', None)
        if not isinstance(overrides, dict) or name not in overrides:
            return
        value = overrides[name].value
        if type_ == ParameterType.PARAMETER_DOUBLE and isinstance(value, int) and not isinstance(value, bool):
            overrides[name] = Parameter(name, Parameter.Type.DOUBLE, float(value))
        elif type_ == ParameterType.PARAMETER_DOUBLE_ARRAY and isinstance(value, (list, tuple)) \
                and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
            overrides[name] = Parameter(name, Parameter.Type.DOUBLE_ARRAY, [float(v) for v in value])

    def _check_override(self, spec: _Spec) -> None:
        # Our message (which names the range or choices) before rclpy's own type/range exceptions.
        overrides = getattr(self._node, '_parameter_overrides', None)
        if not isinstance(overrides, dict) or spec.name not in overrides:
            return
        parameter = overrides[spec.name]
        if parameter.type_ != Parameter.Type(spec.type):
            raise ConfigurationError(f'parameter {spec.name}: must be {_TYPE_WORDS[spec.type]} '
                                     f'(got {echo(parameter.value)})')
        value = parameter.value
        if isinstance(value, (list, tuple)) and not isinstance(value, str):
            value = list(value)
        problem = spec.problem(value)
        if problem is not None:
            raise ConfigurationError(f'parameter {spec.name}: {problem}')

    def __getitem__(self, name: str) -> Any:
        value = self._node.get_parameter(name).value
        if isinstance(value, (list, tuple)) and not isinstance(value, str):
            value = list(value)
        return value

    def dynamic(self) -> list[str]:
        """Names of the parameters that can change at run time."""
        return [name for name, spec in self._specs.items() if spec.on_change is not None]

    # --- setting at run time -------------------------------------------------------------------
    def _on_set(self, parameters: list[Parameter]) -> SetParametersResult:
        if self._declaring:
            return SetParametersResult(successful=True)
        changes = []
        for parameter in parameters:
            spec = self._specs.get(parameter.name)
            if spec is None:
                continue  # rclpy's own (use_sim_time) or another helper's
            value = parameter.value
            if isinstance(value, (list, tuple)) and not isinstance(value, str):
                value = list(value)
            problem = spec.problem(value)
            if problem is not None:
                return SetParametersResult(successful=False, reason=f'parameter {spec.name}: {problem}')
            changes.append((spec, value))
        for spec, value in changes:
            if spec.on_change is None:  # rclpy refuses read-only parameters before this callback
                return SetParametersResult(successful=False,
                                           reason=f'parameter {spec.name}: read-only (set it at start-up)')
        for spec, value in changes:
            try:
                spec.on_change(value)
            except (ValueError, ConfigurationError) as error:
                return SetParametersResult(successful=False, reason=f'parameter {spec.name}: {error}')
        return SetParametersResult(successful=True)

    def refuse_use_sim_time(self, reason: str) -> None:
        """For the clock source: use_sim_time true at start is a ConfigurationError, and so is a set."""
        if self._node.get_parameter('use_sim_time').value:
            raise ConfigurationError(f'parameter use_sim_time: must be false ({reason})')

        def refuse(parameters: list[Parameter]) -> SetParametersResult:
            for parameter in parameters:
                if parameter.name == 'use_sim_time' and parameter.value:
                    return SetParametersResult(successful=False, reason=f'use_sim_time: must stay false ({reason})')
            return SetParametersResult(successful=True)

        self._node.add_on_set_parameters_callback(refuse)

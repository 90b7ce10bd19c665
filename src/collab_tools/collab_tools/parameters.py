"""Declared ROS parameters that are either applied or refused, never silently ignored.

A node's parameters are written once, as a :class:`~collab_tools.core.settings.SettingsSchema` in
its package's core (unit tested without ROS), and declared here::

    self.params = NodeParameters(self)
    values = self.params.declare_schema(BRIDGE_SETTINGS, on_change={'real_time_factor': self._set_rate})

or one at a time::

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
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, ParameterType, \
    SetParametersResult
from rclpy.node import Node
from rclpy.parameter import Parameter

from .core.settings import KIND_WORDS, Setting, SettingsSchema, echo
from .node_support import ConfigurationError
from .sim_clock import guard_sim_clock

_PARAMETER_TYPES = {
    'bool': ParameterType.PARAMETER_BOOL, 'integer': ParameterType.PARAMETER_INTEGER,
    'double': ParameterType.PARAMETER_DOUBLE, 'string': ParameterType.PARAMETER_STRING,
    'bool_array': ParameterType.PARAMETER_BOOL_ARRAY, 'integer_array': ParameterType.PARAMETER_INTEGER_ARRAY,
    'double_array': ParameterType.PARAMETER_DOUBLE_ARRAY, 'string_array': ParameterType.PARAMETER_STRING_ARRAY}


class _Spec:
    """A declared setting with its ROS type and applier."""

    def __init__(self, setting: Setting, type_: int, on_change: Callable[[Any], None] | None):
        self.setting = setting
        self.name = setting.name
        self.type = type_
        self.on_change = on_change

    def problem(self, value: Any) -> str | None:
        return self.setting.problem(value)


class NodeParameters:
    """The declared parameters of one node; see the module docstring."""

    def __init__(self, node: Node):
        self._node = node
        self._specs: dict[str, _Spec] = {}
        self._declaring = False
        node.add_on_set_parameters_callback(self._on_set)
        # Every node declares its parameters here: its simulated clock is guarded here too.
        guard_sim_clock(node)

    # --- declaring ---------------------------------------------------------------------------
    def declare(self, name: str, default: Any, description: str, *,
                low: float | None = None, high: float | None = None,
                low_open: bool = False, high_open: bool = False,
                choices: Sequence[str] | None = None, length: int | None = None,
                required: bool = False, check: Callable[[Any], str | None] | None = None,
                on_change: Callable[[Any], None] | None = None) -> Any:
        """Declare one parameter (see :class:`~collab_tools.core.settings.Setting`) and return its
        start-up value; ``on_change(value)`` makes it dynamic (applied on set), else it is read-only."""
        setting = Setting(name, default, description, low=low, high=high, low_open=low_open, high_open=high_open,
                          choices=choices, length=length, required=required, check=check,
                          dynamic=on_change is not None)
        return self.declare_setting(setting, on_change)

    def declare_schema(self, schema: SettingsSchema,
                       on_change: Mapping[str, Callable[[Any], None]] | None = None) -> dict[str, Any]:
        """Declare every setting of ``schema``; ``on_change`` has an applier for each dynamic one.
        Returns the start-up values by name."""
        on_change = dict(on_change or {})
        missing = [s.name for s in schema if s.dynamic and s.name not in on_change]
        extra = [n for n in on_change if n not in schema or not schema[n].dynamic]
        if missing or extra:  # a programming error: a dynamic setting nobody applies, or the reverse
            raise TypeError(f'on_change must name exactly the dynamic settings (missing: {missing}, not dynamic: {extra})')
        return {s.name: self.declare_setting(s, on_change.get(s.name)) for s in schema}

    def declare_setting(self, setting: Setting, on_change: Callable[[Any], None] | None = None) -> Any:
        """Declare ``setting`` as a ROS parameter and return its start-up value (ConfigurationError if
        it breaks a constraint)."""
        if setting.dynamic != (on_change is not None):
            raise TypeError(f'parameter {setting.name}: a dynamic setting needs on_change, a read-only one none')
        type_ = _PARAMETER_TYPES[setting.kind]
        name, low, high = setting.name, setting.low, setting.high
        spec = _Spec(setting, type_, on_change)
        descriptor = ParameterDescriptor(name=name, type=type_, description=setting.description,
                                         additional_constraints=setting.constraints_text(),
                                         read_only=on_change is None)
        if low is not None or high is not None:
            if setting.kind in ('integer', 'integer_array'):
                from_value = int(math.ceil(low)) if low is not None else -2**63
                to_value = int(math.floor(high)) if high is not None else 2**63 - 1
                descriptor.integer_range = [IntegerRange(from_value=from_value, to_value=to_value, step=0)]
            elif setting.kind in ('double', 'double_array'):
                descriptor.floating_point_range = [FloatingPointRange(
                    from_value=float(low) if low is not None else -math.inf,
                    to_value=float(high) if high is not None else math.inf, step=0.0)]
        self._coerce_integer_override(name, type_)
        self._check_override(spec)
        self._specs[name] = spec
        self._declaring = True
        try:
            self._node.declare_parameter(name, setting.default, descriptor)
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
            raise ConfigurationError(f'parameter {spec.name}: must be {KIND_WORDS[spec.setting.kind]} '
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

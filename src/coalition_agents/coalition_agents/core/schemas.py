"""Schemas (ES, EPS, PS, reduction PS, MS, CS), their costs and the schema library.

Paper, Sections III and IV-B:

* ES -- environmental sensor; EPS -- the perceptual schema designed for an ES. An ES-EPS
  pair is a leaf of a solution space and retrieves one information instance label
  (:class:`SensorSchema`). A *prior* source is the paper's "dummy sensor" for information
  provided a priori (F_G(goal), F_M in the navigation task); it costs ``costs.prior``.
* RPS -- reduction perceptual schema (Section IV-B): an information conversion in IQ form
  (Definition 4.5, Lemma 4.1), ``A + B => C`` (:class:`Conversion`, kind ``rps``). Table I's
  RPSs are in ``config/coalitions/schemas.yaml``. A robot's capability file may add its own
  PSs in the same form (kind ``ps``, e.g. laser localisation); they behave like RPSs but only
  exist on that robot.
* MS -- motor schema, the sink a task activates; CS -- communication schema, a leaf that
  requests information from other robots (or the root of a space answering a request).

Costs (Section V-A-1): ``cost(RPS) = 0.5, cost(ES-EPS) = 1.0, cost(CS) = 2.0, cost(MS) = 4.0``;
a potential solution costs the sum of its schemas (:class:`Costs`, ``config/coalitions/costs.yaml``).
Not in the paper (our choices): ``ps`` (a robot-specific PS, default like an RPS), ``prior``
(a priori information, 0 as in the paper's "incur no costs") and per-MS overrides such as the
helper's "MS to maintain the relative position" whose cost is 6 in footnote 14.
"""
from __future__ import annotations

import enum
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

from collab_tools.core.fields import Fields, check_name, check_number, load_config_file

from .errors import ConfigError, InformationError
from .information import (
    EntityCatalog, InformationInstance, InformationType, InformationTypes, Variable,
    check_entity_name, fresh_variable, match_template, parse_instance, split_conversion,
)


class SchemaKind(str, enum.Enum):
    """Kinds of nodes in solution spaces; the value is the key of its cost in costs.yaml."""

    MS = 'ms'
    CS = 'cs'
    ES_EPS = 'es_eps'
    RPS = 'rps'
    PS = 'ps'
    PRIOR = 'prior'

    @property
    def short(self) -> str:
        """The paper's abbreviation, used when printing solutions."""
        return {'ms': 'MS', 'cs': 'CS', 'es_eps': 'EPS', 'rps': 'RPS', 'ps': 'PS', 'prior': 'PRIOR'}[self.value]

    @property
    def is_leaf(self) -> bool:
        return self in (SchemaKind.CS, SchemaKind.ES_EPS, SchemaKind.PRIOR)


# --- Costs ---------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Costs:
    """Activation cost of each schema kind (paper defaults) and per-motor-schema overrides."""

    rps: float = 0.5
    ps: float = 0.5
    es_eps: float = 1.0
    cs: float = 2.0
    ms: float = 4.0
    prior: float = 0.0
    motor_schemas: Mapping[str, float] = field(default_factory=dict)

    def of(self, kind: SchemaKind) -> float:
        return float(getattr(self, kind.value))

    def motor_schema(self, name: str) -> float:
        return float(self.motor_schemas.get(name, self.ms))

    def __hash__(self) -> int:
        return hash((self.rps, self.ps, self.es_eps, self.cs, self.ms, self.prior,
                     tuple(sorted(self.motor_schemas.items()))))


COST_FIELDS = ('rps', 'ps', 'es_eps', 'cs', 'ms', 'prior', 'motor_schemas')


def costs_from_dict(data: Any, path: str = '') -> Costs:
    """Read costs; reasoning schemas must cost > 0 so that every loop adds cost (termination)."""
    section = Fields(data, path, COST_FIELDS, error=ConfigError)
    defaults = Costs()
    values = {key: section.number(key, getattr(defaults, key), gt=0.0) for key in ('rps', 'ps', 'es_eps', 'cs')}
    values.update({key: section.number(key, getattr(defaults, key), ge=0.0) for key in ('ms', 'prior')})
    overrides = {name: check_number(value, entry_path, ge=0.0, error=ConfigError)
                 for entry_path, name, value in section.entries('motor_schemas', [])}
    return Costs(motor_schemas=overrides, **values)


def load_costs(path: str | Path) -> Costs:
    return load_config_file(path, lambda data: costs_from_dict(data, ''), ConfigError)


# --- Sensors (ES-EPS pairs and prior sources) -----------------------------------------------------

@dataclass(frozen=True)
class SensorSchema:
    """An ES-EPS pair (or a prior source): sensor ``sensor`` retrieves instances of ``output``.

    ``output`` is a label such as ``F_R(X, local)``: the fiducial retrieves the position of
    some entity X relative to the local robot; X is instantiated from the actual reading.
    """

    sensor: str
    output: InformationInstance
    kind: SchemaKind = SchemaKind.ES_EPS

    def retrieves(self, requirement: InformationInstance) -> bool:
        """Whether this pair can be the source of ``requirement`` (no label conflict)."""
        return match_template(self.output, requirement) is not None

    def describe(self) -> str:
        return f'{self.kind.short} {self.sensor}: {self.output}'


# --- Conversions (RPS and robot-specific PS) ------------------------------------------------------

@dataclass(frozen=True)
class Conversion:
    """An information conversion in IQ form (Definition 4.5): ``inputs[0] + ... => output``."""

    name: str
    inputs: tuple[InformationInstance, ...]
    output: InformationInstance
    kind: SchemaKind = SchemaKind.RPS
    description: str = ''

    def __post_init__(self) -> None:
        text = self.text()
        if not self.inputs:
            raise InformationError(f"'{text}': a conversion needs at least one input")
        for instance in (*self.inputs, self.output):
            if instance.is_degenerate:
                raise InformationError(f"'{text}': {instance} names a referent twice")
        input_variables = {v for instance in self.inputs for v in instance.variables}
        invented = [str(v) for v in self.output.variables if v not in input_variables]
        if invented:
            raise InformationError(f"'{text}': output variable(s) {', '.join(invented)} appear in no "
                                   f"input (a conversion cannot invent an entity)")

    def text(self) -> str:
        return f"{' + '.join(str(i) for i in self.inputs)} => {self.output}"

    def describe(self) -> str:
        return f'{self.kind.short} {self.name}: {self.text()}'

    def inputs_for(self, requirement: InformationInstance
                   ) -> tuple[tuple[InformationInstance, ...], tuple[Variable, ...]] | None:
        """The inputs needed to produce ``requirement``, and the fresh variables they introduce.

        Algorithm 1, "populate the instantiations in the RPS based on the information label":
        output referents bind the template's variables; the other template variables become
        fresh variables (the template's own name unless the requirement already uses it, then
        with a number). Returns None on a conflict (the output does not match, or an input
        would name the same entity twice -- the referent instantiation constraint).
        """
        binding = match_template(self.output, requirement)
        if binding is None:
            return None
        used = {v.name for v in requirement.variables}
        fresh: list[Variable] = []
        for instance in self.inputs:
            for variable in instance.variables:
                if variable not in binding:
                    new = fresh_variable(variable.name, used)
                    used.add(new.name)
                    binding[variable] = new
                    fresh.append(new)
        inputs = tuple(instance.substitute(binding) for instance in self.inputs)
        if any(instance.is_degenerate for instance in inputs):
            return None
        return inputs, tuple(fresh)


def parse_conversion(name: str, text: object, types: InformationTypes, catalog: EntityCatalog,
                     kind: SchemaKind = SchemaKind.RPS, description: str = '') -> Conversion:
    left, right = split_conversion(text)
    inputs = tuple(parse_instance(part, types, catalog) for part in left)
    output = parse_instance(right, types, catalog)
    return Conversion(name, inputs, output, kind, description)


def conversions_from_list(items: Sequence[tuple[str, Any]], types: InformationTypes,
                          catalog: EntityCatalog, kind: SchemaKind,
                          taken: set[str] | None = None) -> tuple[Conversion, ...]:
    """Read ``[{name, conversion, description}]`` entries (schema library or capability file)."""
    names = set() if taken is None else taken
    conversions = []
    for path, item in items:
        section = Fields(item, path, ('name', 'conversion', 'description'), error=ConfigError)
        name = section.name('name')
        if name in names:
            raise ConfigError(f"{section.path_of('name')}: schema name '{name}' is used twice")
        names.add(name)
        try:
            conversions.append(parse_conversion(name, section.raw('conversion'), types, catalog, kind,
                                                section.string('description', '', allow_empty=True)))
        except InformationError as exc:
            raise ConfigError(f"{section.path_of('conversion')}: {exc}") from None
    return tuple(conversions)


# --- The library: information types, objects and RPSs ----------------------------------------

@dataclass(frozen=True)
class SchemaLibrary:
    """A domain's information types, the non-robot entities it names and its RPSs."""

    types: InformationTypes
    catalog: EntityCatalog
    reductions: tuple[Conversion, ...]

    def parse(self, text: object, robots: Sequence[str] = ()) -> InformationInstance:
        """Parse an instance naming library objects, ``local`` or the given robots."""
        catalog = self.catalog.with_robots(robots) if robots else self.catalog
        return parse_instance(text, self.types, catalog)

    def reduction(self, name: str) -> Conversion:
        for conversion in self.reductions:
            if conversion.name == name:
                return conversion
        raise KeyError(name)

    def __hash__(self) -> int:
        return id(self)


LIBRARY_FIELDS = ('information_types', 'objects', 'reduction_schemas')


def library_from_dict(data: Any, path: str = '') -> SchemaLibrary:
    section = Fields(data, path, LIBRARY_FIELDS, error=ConfigError)
    types = []
    for entry_path, label, value in section.entries('information_types'):
        entry = Fields(value, entry_path, ('referents', 'description'), error=ConfigError)
        referents = entry.number('referents', ge=0.0)
        if referents != int(referents):
            raise ConfigError(f"{entry.path_of('referents')}: must be a whole number (got {referents})")
        types.append(InformationType(label, int(referents), entry.string('description', '', allow_empty=True)))
    registry = InformationTypes(types)
    objects = []
    for item_path, item in section.items('objects', []):
        try:
            objects.append(check_entity_name(check_name(item, item_path, ConfigError)))
        except InformationError as exc:
            raise ConfigError(f'{item_path}: {exc}') from None
    if len(set(objects)) != len(objects):
        raise ConfigError(f"{section.path_of('objects')}: an object is listed twice")
    catalog = EntityCatalog(objects=frozenset(objects))
    reductions = conversions_from_list(section.items('reduction_schemas', []), registry, catalog, SchemaKind.RPS)
    return SchemaLibrary(registry, catalog, reductions)


def load_library(path: str | Path) -> SchemaLibrary:
    return load_config_file(path, lambda data: library_from_dict(data, ''), ConfigError)


def check_listed_names(items: Sequence[tuple[str, Any]]) -> tuple[str, ...]:
    """Names in a YAML list, each valid and unique."""
    names: list[str] = []
    for path, item in items:
        name = check_name(item, path, ConfigError)
        if name in names:
            raise ConfigError(f"{path}: '{name}' is listed twice")
        names.append(name)
    return tuple(names)


def parse_field_instance(library: SchemaLibrary, value: Any, path: str,
                         robots: Sequence[str] = ()) -> InformationInstance:
    """Parse an instance at a config path, turning parse errors into path-prefixed ConfigErrors."""
    try:
        return library.parse(value, robots)
    except InformationError as exc:
        raise ConfigError(f'{path}: {exc}') from None


__all__ = [
    'COST_FIELDS', 'Conversion', 'Costs', 'SchemaKind', 'SchemaLibrary', 'SensorSchema',
    'check_listed_names', 'conversions_from_list', 'costs_from_dict',
    'library_from_dict', 'load_costs', 'load_library', 'parse_conversion', 'parse_field_instance',
]

"""Information types, information instances, referents and the generality order.

Paper (IQ-ASyMTRe, Zhang & Parker, IEEE Transactions on Robotics; CITATION.cff), Section IV-A:

* Definition 4.1 -- an *information type* is a pair (F, N): a label with a semantic meaning
  and the number of referents (:class:`InformationType`, registry :class:`InformationTypes`).
* Definition 4.2 -- an *information instance* F(Ref_1:N) of a type; each referent is either
  *instantiated* to an entity or *uninstantiated* (a variable to be instantiated later)
  (:class:`InformationInstance`, :class:`Entity`, :class:`Variable`).
* Definition 4.3 -- the *generality* partial order between instances of the same type
  (:func:`is_more_general`, :func:`has_same_generality`, :func:`compare_generality`).

Text notation (config files, logs): ``F_R(X, local)``, ``F_G(goal)``, ``F_M`` (no referents).

* A **variable** (uninstantiated referent) is a single capital letter optionally followed
  by digits: ``X``, ``Z``, ``Z1``. (The paper writes X, Y, Z; fresh variables get digits.)
* ``local`` is the robot doing the reasoning (the paper's *local* entity).
* Any other name is an **entity** that must be known: a non-robot *object* declared in the
  schema library (``goal``, ``box``, ``target``) or a robot named in a team. Robot and object
  names therefore must not look like variables (``robot_1``, not ``R1``).

Entities carry whether they are robots, because the Localness in Reasoning constraint treats
"all referents instantiated to non-robot entities" specially.
"""
from __future__ import annotations

import itertools
import re
from dataclasses import dataclass
from typing import Iterable, Iterator, Mapping, Sequence, Union

from .errors import InformationError

VARIABLE_PATTERN = re.compile(r'[A-Z][0-9]*\Z')
IDENTIFIER_PATTERN = re.compile(r'[A-Za-z][A-Za-z0-9_]*\Z')
LOCAL_NAME = 'local'

#: Preferred names of canonical variables, in order (then X1, Y1, Z1, W1, X2, ...).
CANONICAL_VARIABLE_LETTERS = ('X', 'Y', 'Z', 'W')


@dataclass(frozen=True)
class Variable:
    """An uninstantiated referent; the same name means the same (future) entity."""

    name: str

    def __str__(self) -> str:
        return self.name


@dataclass(frozen=True)
class Entity:
    """An instantiated referent: a robot (``robot=True``, including ``local``) or an object."""

    name: str
    robot: bool

    def __str__(self) -> str:
        return self.name

    @property
    def is_local(self) -> bool:
        return self.name == LOCAL_NAME


Referent = Union[Variable, Entity]

#: The reasoning robot itself, as it appears in solution spaces (replaced by its name in messages).
LOCAL = Entity(LOCAL_NAME, robot=True)


def referent_sort_key(referent: Referent) -> tuple[int, str, int]:
    """Total order on referents (entities before variables) for deterministic sorting."""
    if isinstance(referent, Entity):
        return (0, referent.name, int(referent.robot))
    return (1, referent.name, 0)


@dataclass(frozen=True)
class InformationType:
    """Definition 4.1: a label F and its number of referents N."""

    label: str
    referents: int
    description: str = ''

    def __str__(self) -> str:
        return f'({self.label}, {self.referents})'


@dataclass(frozen=True)
class InformationInstance:
    """Definition 4.2: F(Ref_1:N), an instance of an information type with its referents."""

    label: str
    referents: tuple[Referent, ...] = ()

    def __hash__(self) -> int:
        # Instances are dictionary keys everywhere in the search: hash once.
        cached = self.__dict__.get('_hash')
        if cached is None:
            cached = hash((self.label, self.referents))
            object.__setattr__(self, '_hash', cached)
        return cached

    def __str__(self) -> str:
        if not self.referents:
            return self.label
        return f'{self.label}({", ".join(str(r) for r in self.referents)})'

    def __repr__(self) -> str:
        return f'InformationInstance({str(self)!r})'

    @property
    def arity(self) -> int:
        return len(self.referents)

    @property
    def instantiated_positions(self) -> frozenset[int]:
        """Indices of the instantiated referents (what Definition 4.3 compares)."""
        return frozenset(i for i, r in enumerate(self.referents) if isinstance(r, Entity))

    @property
    def is_fully_instantiated(self) -> bool:
        """Fully instantiated instances are actual information; others name a class of it."""
        return all(isinstance(r, Entity) for r in self.referents)

    @property
    def variables(self) -> tuple[Variable, ...]:
        """The distinct variables, in order of appearance."""
        seen: dict[Variable, None] = {}
        for referent in self.referents:
            if isinstance(referent, Variable):
                seen.setdefault(referent)
        return tuple(seen)

    @property
    def has_local(self) -> bool:
        return LOCAL in self.referents

    @property
    def is_degenerate(self) -> bool:
        """True when two referents are the same entity or variable.

        Instantiating two referents of one instance to the same entity is not informative
        (paper, proof of Lemma 4.4 b); such instances violate the referent instantiation
        constraint and are never generated or accepted.
        """
        return len(set(self.referents)) != len(self.referents)

    def substitute(self, mapping: Mapping[Variable, Referent]) -> 'InformationInstance':
        """Replace variables by the referents ``mapping`` gives them (others are kept)."""
        if not mapping:
            return self
        return InformationInstance(self.label, tuple(
            mapping.get(r, r) if isinstance(r, Variable) else r for r in self.referents))

    def replace_entity(self, old: Entity, new: Referent) -> 'InformationInstance':
        """Replace one entity everywhere (e.g. ``local`` by the robot's name for a message)."""
        if old not in self.referents:
            return self
        return InformationInstance(self.label, tuple(new if r == old else r for r in self.referents))


# --- Definition 4.3: generality ------------------------------------------------------------

def _same_type(fx: InformationInstance, fy: InformationInstance) -> bool:
    return fx.label == fy.label and fx.arity == fy.arity


def is_more_general(fx: InformationInstance, fy: InformationInstance) -> bool:
    """F^x > F^y (Definition 4.3): F^y instantiates a referent that F^x does not, and every
    referent F^x instantiates is instantiated in F^y. Instances of different types are
    not comparable (False)."""
    if not _same_type(fx, fy):
        return False
    inst_x, inst_y = fx.instantiated_positions, fy.instantiated_positions
    return inst_x < inst_y


def has_same_generality(fx: InformationInstance, fy: InformationInstance) -> bool:
    """F^x = F^y (Definition 4.3): exactly the same referent positions are instantiated
    (the entities themselves may differ)."""
    if not _same_type(fx, fy):
        return False
    return fx.instantiated_positions == fy.instantiated_positions


def compare_generality(fx: InformationInstance, fy: InformationInstance) -> str | None:
    """'>' if fx is more general, '<' if less, '=' if as general, None if not comparable."""
    if has_same_generality(fx, fy):
        return '='
    if is_more_general(fx, fy):
        return '>'
    if is_more_general(fy, fx):
        return '<'
    return None


# --- Registry of types and known entities --------------------------------------------------

class InformationTypes:
    """The information types of a domain, by label."""

    def __init__(self, types: Iterable[InformationType]):
        self._types: dict[str, InformationType] = {}
        for info_type in types:
            if info_type.label in self._types:
                raise InformationError(f"information type '{info_type.label}' defined twice")
            self._types[info_type.label] = info_type

    def __contains__(self, label: str) -> bool:
        return label in self._types

    def __iter__(self) -> Iterator[InformationType]:
        return iter(self._types.values())

    def __len__(self) -> int:
        return len(self._types)

    @property
    def labels(self) -> tuple[str, ...]:
        return tuple(sorted(self._types))

    def get(self, label: str) -> InformationType:
        try:
            return self._types[label]
        except KeyError:
            raise InformationError(f"unknown information type '{label}' "
                                   f"(known: {', '.join(self.labels) or 'none'})") from None

    def check(self, instance: InformationInstance) -> InformationInstance:
        """Return ``instance`` if its label is known and its number of referents matches."""
        info_type = self.get(instance.label)
        if instance.arity != info_type.referents:
            raise InformationError(
                f"{instance}: information type {instance.label} has {info_type.referents} "
                f"referent{'s' if info_type.referents != 1 else ''} (got {instance.arity})")
        return instance


@dataclass(frozen=True)
class EntityCatalog:
    """Names that may appear as instantiated referents: objects and robots (``local`` is implicit)."""

    objects: frozenset[str] = frozenset()
    robots: frozenset[str] = frozenset()

    def __post_init__(self) -> None:
        for name in sorted(self.objects | self.robots):
            check_entity_name(name)
        both = self.objects & self.robots
        if both:
            raise InformationError(f"names used for both robots and objects: {', '.join(sorted(both))}")

    def with_robots(self, robots: Iterable[str]) -> 'EntityCatalog':
        return EntityCatalog(self.objects, self.robots | frozenset(robots))

    def with_objects(self, objects: Iterable[str]) -> 'EntityCatalog':
        return EntityCatalog(self.objects | frozenset(objects), self.robots)

    def entity(self, name: str) -> Entity:
        if name == LOCAL_NAME:
            return LOCAL
        if name in self.robots:
            return Entity(name, robot=True)
        if name in self.objects:
            return Entity(name, robot=False)
        raise InformationError(
            f"unknown entity '{name}' (objects: {', '.join(sorted(self.objects)) or 'none'}; "
            f"robots: {', '.join(sorted(self.robots)) or 'none'}; 'local' is the reasoning robot; "
            f"a variable is one capital letter optionally followed by digits, e.g. X or Z1)")


def check_entity_name(name: object) -> str:
    """Validate a robot or object name: an identifier that does not look like a variable."""
    if not isinstance(name, str) or not IDENTIFIER_PATTERN.match(name):
        raise InformationError(f'invalid entity name {name!r} (must match [A-Za-z][A-Za-z0-9_]*)')
    if VARIABLE_PATTERN.match(name):
        raise InformationError(f"entity name '{name}' looks like a variable "
                               f"(one capital letter and digits); rename it, e.g. '{name.lower()}_'")
    if name == LOCAL_NAME:
        raise InformationError("'local' is reserved for the reasoning robot")
    return name


# --- Text parsing ----------------------------------------------------------------------------

_INSTANCE_PATTERN = re.compile(r'\s*([A-Za-z][A-Za-z0-9_]*)\s*(?:\(([^()]*)\))?\s*\Z')


def parse_instance(text: object, types: InformationTypes, catalog: EntityCatalog) -> InformationInstance:
    """Parse ``'F_R(X, local)'`` into an instance, checking the type, arity and entities."""
    if not isinstance(text, str):
        raise InformationError(f'an information instance must be a string like F_R(X, local) (got {text!r})')
    match = _INSTANCE_PATTERN.match(text)
    if not match:
        hint = ''
        if text.count('(') != text.count(')'):
            # [F_R(X, local)] in a YAML flow list is split at the comma.
            hint = "; in a YAML list write labels with commas in quotes: ['F_R(X, local)']"
        raise InformationError(f"malformed information instance '{text}' "
                               f"(expected LABEL or LABEL(ref, ...), e.g. F_R(X, local){hint})")
    label, inside = match.group(1), match.group(2)
    names = [] if inside is None or not inside.strip() else [part.strip() for part in inside.split(',')]
    referents: list[Referent] = []
    for name in names:
        if not IDENTIFIER_PATTERN.match(name):
            raise InformationError(f"malformed referent '{name}' in '{text}'")
        referents.append(Variable(name) if VARIABLE_PATTERN.match(name) else catalog.entity(name))
    instance = types.check(InformationInstance(label, tuple(referents)))
    if instance.is_degenerate:
        raise InformationError(f"'{text}': a referent appears twice (two referents of one instance "
                               f"must be different entities)")
    return instance


def split_conversion(text: object) -> tuple[list[str], str]:
    """Split ``'A + B => C'`` (``⇒`` accepted) into (['A', 'B'], 'C'), enforcing the IQ form."""
    if not isinstance(text, str):
        raise InformationError(f"a conversion must be a string like 'F_R(Y, X) => F_R(X, Y)' (got {text!r})")
    normalized = text.replace('⇒', '=>')
    if normalized.count('=>') != 1:
        raise InformationError(f"malformed conversion '{text}' (expected exactly one '=>')")
    left, right = (part.strip() for part in normalized.split('=>'))
    if 'iOR' in left or '|' in left:
        raise InformationError(f"'{text}': iOR on the left is not in IQ form (Lemma 4.1: "
                               f"write one conversion per conjunctive clause)")
    if '+' in right or 'iAND' in right:
        raise InformationError(f"'{text}': the IQ form has a single instance on the right "
                               f"(Lemma 4.1: write one conversion per output instance)")
    inputs = [part.strip() for part in left.replace('iAND', '+').split('+')]
    if not right or any(not part for part in inputs):
        raise InformationError(f"malformed conversion '{text}' (an empty side or an empty '+' operand)")
    return inputs, right


# --- Matching and binding ----------------------------------------------------------------------

def extend_binding(template: InformationInstance, target: InformationInstance,
                   binding: Mapping[Variable, Referent]) -> dict[Variable, Referent] | None:
    """``binding`` extended so that ``template`` equals ``target``, or None on a conflict: the
    types differ, a template entity differs from the target's referent, or a template variable
    would name two different referents (the referent instantiation constraint)."""
    if template.label != target.label or template.arity != target.arity:
        return None
    extended = dict(binding)
    for mine, theirs in zip(template.referents, target.referents):
        if isinstance(mine, Variable):
            if extended.setdefault(mine, theirs) != theirs:
                return None
        elif mine != theirs:
            return None
    return extended


def match_template(template: InformationInstance,
                   target: InformationInstance) -> dict[Variable, Referent] | None:
    """Bind the template's variables so that it equals ``target``, or None on a conflict.

    Used for a schema's output label against a required instance (Algorithm 1: "no
    conflict occurs between the information label and the EPS label"). A template entity
    must equal the target's referent; a target *variable* is only matched by a template
    variable -- bindings flow from the requirement into the schema (downstream to upstream),
    never sideways into sibling branches, so a schema cannot fix an entity the requirement
    leaves open; that entity is instantiated at run time from the retrieved information.
    """
    return extend_binding(template, target, {})


def bind_to_ground(label: InformationInstance, ground: InformationInstance,
                   binding: Mapping[Variable, Entity]) -> dict[Variable, Entity] | None:
    """Extend ``binding`` so ``label`` equals the fully instantiated ``ground``, or None.

    This is the referent instantiation constraint at run time: the same variable must be
    instantiated to the same entity everywhere in a potential solution.
    """
    if not ground.is_fully_instantiated:
        return None
    return extend_binding(label, ground, binding)  # type: ignore[return-value]


# --- Variable naming -----------------------------------------------------------------------------

def canonical_variable_names() -> Iterator[str]:
    """X, Y, Z, W, X1, Y1, Z1, W1, X2, ..."""
    yield from CANONICAL_VARIABLE_LETTERS
    for index in itertools.count(1):
        for letter in CANONICAL_VARIABLE_LETTERS:
            yield f'{letter}{index}'


def fresh_variable(base: str, used: Iterable[str] | set[str]) -> Variable:
    """``base`` if unused, else ``base`` followed by the smallest free number (Z, Z1, Z2...)."""
    taken = used if isinstance(used, (set, frozenset)) else set(used)
    if base not in taken:
        return Variable(base)
    letter = base[0]
    for index in itertools.count(1):
        name = f'{letter}{index}'
        if name not in taken:
            return Variable(name)
    raise AssertionError('unreachable')


def canonical_instance(instance: InformationInstance) -> InformationInstance:
    """Rename variables in order of appearance to X, Y, Z, ... (equal up to renaming => equal)."""
    names = canonical_variable_names()
    return instance.substitute({v: Variable(next(names)) for v in instance.variables})


def format_instances(instances: Sequence[InformationInstance]) -> str:
    return ' + '.join(str(i) for i in instances)

"""And-or tree nodes and potential solutions (paper Section IV-C/G): the tOR choice
(:class:`RequirementNode`), a schema needing all its inputs (:class:`SchemaNode`), one picked
alternative per tOR node (:class:`PotentialSolution`, its steps :class:`SolutionStep`) and the
information key that removes dominated solutions (Section V-A-1). Built by :mod:`.solution_space`."""
from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Iterable, Iterator, Mapping, Sequence

from .information import Entity, InformationInstance, Variable
from .schemas import SchemaKind


#: Costs are compared after rounding so that float noise (0.1 + 0.2) never reorders ties.
COST_DIGITS = 9
#: Above this many variable permutations, :func:`information_key` uses refinement only.
MAX_CANONICAL_PERMUTATIONS = 720


class SchemaNode:
    """An AND node: one schema; it needs all its ``inputs``. Leaves have no inputs."""

    __slots__ = ('uid', 'kind', 'schema', 'output', 'inputs', 'fresh', 'cost')

    def __init__(self, uid: int, kind: SchemaKind, schema: str, output: InformationInstance | None,
                 inputs: tuple['RequirementNode', ...], fresh: tuple[Variable, ...], cost: float):
        self.uid, self.kind, self.schema, self.output = uid, kind, schema, output
        self.inputs, self.fresh, self.cost = inputs, fresh, cost

    def __repr__(self) -> str:
        return f'SchemaNode({self.kind.short} {self.schema} -> {self.output})'


class RequirementNode:
    """A tOR node: the alternative schemas that can provide ``instance``."""

    __slots__ = ('uid', 'instance', 'options')

    def __init__(self, uid: int, instance: InformationInstance, options: tuple[SchemaNode, ...]):
        self.uid, self.instance, self.options = uid, instance, options

    def __repr__(self) -> str:
        return f'RequirementNode({self.instance}, {len(self.options)} options)'


# --- Potential solutions -------------------------------------------------------------------------

@dataclass(frozen=True)
class SolutionStep:
    """One schema of a potential solution, with the steps feeding its inputs."""

    kind: SchemaKind
    schema: str
    output: InformationInstance | None
    inputs: tuple['SolutionStep', ...] = ()
    cost: float = 0.0

    @property
    def is_leaf(self) -> bool:
        return not self.inputs and self.kind is not SchemaKind.MS

    def walk(self) -> Iterator['SolutionStep']:
        """Pre-order: this step, then each input's steps in input order."""
        yield self
        for step in self.inputs:
            yield from step.walk()

    def leaves(self) -> tuple['SolutionStep', ...]:
        return tuple(step for step in self.walk() if step.is_leaf)

    def describe(self) -> str:
        """One line in the paper's style, e.g. ``RPS relative_inverse: F_R(X, local) => F_R(local, X)``."""
        if self.kind is SchemaKind.MS:
            return f'MS {self.schema}'
        if self.kind in (SchemaKind.RPS, SchemaKind.PS):
            sources = ' + '.join(str(step.output) for step in self.inputs)
            return f'{self.kind.short} {self.schema}: {sources} => {self.output}'
        if self.kind is SchemaKind.CS and self.inputs:
            return f'CS reply: {self.output}'
        if self.kind is SchemaKind.CS:
            return f'CS: {self.output}'
        return f'{self.kind.short} {self.schema}: {self.output}'


@dataclass(frozen=True)
class PotentialSolution:
    """A trimmed solution space: one way to connect schemas on this robot (Section IV-C)."""

    root: SolutionStep
    cost: float
    rank: int
    fixed_variables: frozenset[str] = frozenset()

    @property
    def leaves(self) -> tuple[SolutionStep, ...]:
        return self.root.leaves()

    @property
    def steps(self) -> tuple[SolutionStep, ...]:
        return tuple(self.root.walk())

    @property
    def information(self) -> tuple:
        """The information this solution needs, canonical up to renaming of its own variables."""
        return information_key(self.leaves, self.fixed_variables)

    def summary(self) -> str:
        """Leaves only, as Table III prints them ("RPSs are not shown for brevity")."""
        return ', '.join(step.describe() for step in self.leaves)

    def schemas(self) -> list[str]:
        return [step.describe() for step in self.root.walk()]

    def to_dict(self) -> dict:
        return {'cost': self.cost, 'summary': self.summary(), 'schemas': self.schemas()}


def _render_referent(referent: object, fixed: frozenset[str], numbering: Mapping[Variable, int]) -> str:
    if isinstance(referent, Entity):
        return f'e:{referent.name}'
    assert isinstance(referent, Variable)
    if referent.name in fixed:
        return f'v:{referent.name}'
    index = numbering.get(referent)
    return '?' if index is None else f'?{index}'


def _render(leaves: Sequence[SolutionStep], fixed: frozenset[str],
            numbering: Mapping[Variable, int]) -> tuple:
    items = []
    for step in leaves:
        instance = step.output
        assert instance is not None
        schema = '' if step.kind is SchemaKind.CS else step.schema
        items.append((step.kind.value, schema, instance.label,
                      tuple(_render_referent(r, fixed, numbering) for r in instance.referents)))
    return tuple(sorted(items))


def information_key(leaves: Sequence[SolutionStep], fixed: frozenset[str] = frozenset()) -> tuple:
    """Canonical form of a set of leaves, equal for sets equal up to renaming variables not in ``fixed``.

    Variables are partitioned by a renaming-invariant signature; the canonical numbering is
    the lexicographically smallest rendering over the permutations within equal-signature
    groups (exact up to :data:`MAX_CANONICAL_PERMUTATIONS`, deterministic beyond).
    """
    free = sorted({r for step in leaves for r in step.output.referents  # type: ignore[union-attr]
                   if isinstance(r, Variable) and r.name not in fixed}, key=lambda v: v.name)
    if not free:
        return _render(leaves, fixed, {})
    signatures: dict[Variable, tuple] = {}
    for variable in free:
        occurrences = []
        for step in leaves:
            instance = step.output
            assert instance is not None
            for position, referent in enumerate(instance.referents):
                if referent == variable:
                    others = tuple('*' if r == variable else _render_referent(r, fixed, {})
                                   for r in instance.referents)
                    occurrences.append((step.kind.value, step.schema if step.kind is not SchemaKind.CS else '',
                                        instance.label, position, others))
        signatures[variable] = tuple(sorted(occurrences))
    groups = [list(group) for _, group in itertools.groupby(
        sorted(free, key=lambda v: (signatures[v], v.name)), key=lambda v: signatures[v])]
    permutations = math.prod(math.factorial(len(g)) for g in groups)
    orderings: Iterable[tuple] = (itertools.product(*(itertools.permutations(g) for g in groups))
                                  if permutations <= MAX_CANONICAL_PERMUTATIONS else [tuple(groups)])
    best = None
    for ordering in orderings:
        numbering = {v: i for i, v in enumerate(itertools.chain.from_iterable(ordering))}
        rendered = _render(leaves, fixed, numbering)
        if best is None or rendered < best:
            best = rendered
    return best  # type: ignore[return-value]


def placeholder_robots(instance: InformationInstance) -> tuple[InformationInstance, dict[Entity, Entity]]:
    """``instance`` with each robot other than ``local`` replaced by a placeholder robot (in order
    of appearance), and the placeholder -> robot renaming back (empty: nothing to replace).
    Placeholder names are not valid entity names, so they never meet a real robot."""
    names: dict[Entity, Entity] = {}
    referents = []
    for referent in instance.referents:
        if isinstance(referent, Entity) and referent.robot and not referent.is_local:
            placeholder = next((p for p, real in names.items() if real == referent), None)
            if placeholder is None:
                placeholder = Entity(f'_robot{len(names) + 1}', robot=True)
                names[placeholder] = referent
            referents.append(placeholder)
        else:
            referents.append(referent)
    return InformationInstance(instance.label, tuple(referents)), names


def rename_entities(solution: PotentialSolution, names: Mapping[Entity, Entity]) -> PotentialSolution:
    """``solution`` with its entities renamed (``names``: old -> new)."""
    def instance(value: InformationInstance | None) -> InformationInstance | None:
        if value is None:
            return None
        for old, new in names.items():
            value = value.replace_entity(old, new)
        return value

    def step(original: SolutionStep) -> SolutionStep:
        return SolutionStep(original.kind, original.schema, instance(original.output),
                            tuple(step(child) for child in original.inputs), original.cost)
    return PotentialSolution(step(solution.root), solution.cost, solution.rank, solution.fixed_variables)

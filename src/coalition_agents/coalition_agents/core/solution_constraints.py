"""The three constraints of Algorithm 1 (paper Section IV-C), as pure predicates: Generality
Imposition (Lemma 4.2), Localness in Reasoning and External Communication; see
:mod:`.solution_space` for how the generator applies them."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

from .errors import CoalitionError
from .information import LOCAL, Entity, InformationInstance


GI_READINGS = ('inputs', 'outputs')


@dataclass(frozen=True)
class Constraints:
    """Which of the solution-space constraints apply (all, unless an ablation turns one off).

    ``generality_reading`` says what the Generality Imposition constraint compares:

    * ``'inputs'`` (default) -- the instances an RPS *converts*, as the constraint is worded:
      "prohibit the use of the same RPS to convert information instances of the same type that
      have less or equal generality upstream". This reproduces Table III exactly (11 potential
      solutions; Section V-A-4: "P(r^(k)) is bounded by 11").
    * ``'outputs'`` -- the instances an RPS *produces*, as the proofs of Lemmas 4.2 and 4.4
      phrase it ("F_u > F_v or F_u = F_v", F_x produced by node x). It also allows composing
      relative positions twice through a fourth entity: two more potential solutions of cost
      14 for F_G(local), which Table III does not list.

    Without Generality Imposition the space is infinite (Lemma 4.2), so ``max_depth`` of
    :class:`SolutionSpaceGenerator` must then bound it.
    """

    generality_imposition: bool = True
    localness_in_reasoning: bool = True
    external_communication: bool = True
    generality_reading: str = 'inputs'

    def __post_init__(self) -> None:
        if self.generality_reading not in GI_READINGS:
            raise CoalitionError(f"generality_reading: must be one of {', '.join(GI_READINGS)} "
                                 f"(got {self.generality_reading!r})")


def localness_allows(instance: InformationInstance) -> bool:
    """LR: may a schema other than a CS provide ``instance`` on this robot?"""
    if instance.has_local:
        return True
    # "except for those with all referents instantiated to nonrobot entities"
    return all(isinstance(r, Entity) and not r.robot for r in instance.referents)


def external_communication_allows(instance: InformationInstance) -> bool:
    """EC: may a CS request ``instance``? Only if some referent is not the local robot."""
    if not instance.referents:
        return True
    return any(r != LOCAL for r in instance.referents)


#: GI context: (schema name, label, instantiated positions) of the instances each RPS/PS
#: compares (converts or produces, see :class:`Constraints`) downstream on the branching path.
GIContext = frozenset


def generality_imposition_allows(schema: str, instances: Sequence[InformationInstance],
                                 downstream: GIContext) -> bool:
    """GI: may ``schema`` be used on ``instances`` given its uses downstream on this path?

    Prohibited when the same schema was used downstream and each of ``instances`` is less or
    as general (Definition 4.3) as an instance of the same type compared there, i.e. its
    instantiated positions include theirs. With one instance (the output, or a one-input
    RPS) this is exactly "F_u > F_v or F_u = F_v"; with several inputs, a use that converts
    at least one instance more general than, or not comparable to, everything converted
    downstream is allowed.
    """
    earlier = [(label, positions) for name, label, positions in downstream if name == schema]
    if not earlier:
        return True
    return not all(any(label == instance.label and positions <= instance.instantiated_positions
                       for label, positions in earlier) for instance in instances)

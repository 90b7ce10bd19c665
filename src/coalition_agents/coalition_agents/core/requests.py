"""Information requests and offers between robots, their addressing and Distinct Requests.

Paper, Sections IV-D/F: a CS of a potential solution sends an *information request* for its
label; "robots that receive an information request create a solution space for the required
information and follow the same search process"; when the information is retrievable they
send it back (here: an :class:`InformationOffer` with the instantiated instance, the helper's
coalition solution and its cost).

Frames. Solution spaces are written for the reasoning robot (``local``); messages name
robots: :func:`to_absolute` / :func:`to_local` convert. A request label keeps its variables
(canonically renamed X, Y, ...): "If we have sent a request for F_G(X), no requests need to
be sent for F_G(r1) or F_G(r2)" (Section IV-H); answers instantiate them.

Addressing (:func:`addressees`; the paper: "information requests are often addressed to all
robots (whenever there are uninstantiated referents)", and a robot may request information
from itself, footnote 10): a label with variables, or naming no robot, goes to every robot;
a fully instantiated label naming robots goes to those robots.

Receiving (:func:`request_variants`, footnote 9): a robot that is a referent answers the label
as it is; otherwise "when there is no referent instantiated to the local entity but there are
uninstantiated referents, the robot checks all possible ways to instantiate one of them to the
local entity"; a label about objects only is answered as it is; a fully instantiated label
about other robots is not for this robot (it could only relay it, which adds a CS and no
information).

Distinct Requests (:class:`RequestLedger`): "For any robot, prohibit the use of CS if the robot
has already used CSs to request the same information instance." A robot sends each label
(equal up to renaming variables) at most once per search; later CSs for it share the answers
of the first request -- as the proof of Lemma 4.4 (a) implements it: "only the first CS
created may send the request". A request also carries its chain (who requested what before
it), so a stateless responder can apply the constraint too.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Iterable, Mapping, Sequence

from .errors import InformationError, RequestError
from .information import (
    LOCAL, Entity, EntityCatalog, InformationInstance, InformationTypes, bind_to_ground, canonical_instance,
    parse_instance,
)


def to_absolute(instance: InformationInstance, robot: str) -> InformationInstance:
    """``local`` -> the robot's name (for messages and coalition solutions)."""
    return instance.replace_entity(LOCAL, Entity(robot, robot=True))


def to_local(instance: InformationInstance, robot: str) -> InformationInstance:
    """The robot's name -> ``local`` (to reason about a received label)."""
    return instance.replace_entity(Entity(robot, robot=True), LOCAL)


def request_label(instance: InformationInstance, robot: str) -> InformationInstance:
    """The label robot ``robot`` sends for a CS leaf: absolute, variables renamed X, Y, ..."""
    return canonical_instance(to_absolute(instance, robot))


@dataclass(frozen=True)
class InformationRequest:
    """A CS's request: ``requester`` needs instances of ``label`` (absolute, canonical)."""

    requester: str
    label: InformationInstance
    chain: tuple[tuple[str, InformationInstance], ...] = ()

    def __str__(self) -> str:
        return f'{self.requester} requests {self.label}'

    @property
    def extended_chain(self) -> tuple[tuple[str, InformationInstance], ...]:
        """The chain a request sent while serving this one carries."""
        return self.chain + ((self.requester, self.label),)

    def to_dict(self) -> dict:
        return {'requester': self.requester, 'label': str(self.label),
                'chain': [{'requester': robot, 'label': str(label)} for robot, label in self.chain]}

    @classmethod
    def from_dict(cls, data: Any, types: InformationTypes, catalog: EntityCatalog) -> 'InformationRequest':
        """Validate a request received from another robot (clear errors, never a crash)."""
        if not isinstance(data, Mapping):
            raise RequestError(f'request: must be a mapping with requester, label, chain (got {type(data).__name__})')
        unknown = sorted(str(k) for k in data if k not in ('requester', 'label', 'chain'))
        if unknown:
            raise RequestError(f"request.{unknown[0]}: unknown field (allowed: requester, label, chain)")
        requester = _robot_field(data.get('requester'), 'request.requester', catalog)
        label = _label_field(data.get('label'), 'request.label', types, catalog)
        chain_data = data.get('chain', [])
        if not isinstance(chain_data, (list, tuple)):
            raise RequestError(f'request.chain: must be a list (got {type(chain_data).__name__})')
        chain = []
        for index, entry in enumerate(chain_data):
            path = f'request.chain[{index}]'
            if not isinstance(entry, Mapping) or set(entry) != {'requester', 'label'}:
                raise RequestError(f'{path}: must be a mapping with requester and label (got {entry!r})')
            chain.append((_robot_field(entry['requester'], f'{path}.requester', catalog),
                          _label_field(entry['label'], f'{path}.label', types, catalog)))
        return cls(requester, label, tuple(chain))


def _robot_field(value: Any, path: str, catalog: EntityCatalog) -> str:
    if not isinstance(value, str):
        raise RequestError(f'{path}: must be a robot name (got {value!r})')
    if value not in catalog.robots:
        raise RequestError(f"{path}: unknown robot '{value}' (team: {', '.join(sorted(catalog.robots)) or 'none'})")
    return value


def _label_field(value: Any, path: str, types: InformationTypes, catalog: EntityCatalog) -> InformationInstance:
    try:
        label = parse_instance(value, types, catalog)
    except InformationError as exc:
        raise RequestError(f'{path}: {exc}') from None
    if label.has_local:
        raise RequestError(f"{path}: a request names robots, not 'local' (got {label})")
    return canonical_instance(label)


def addressees(label: InformationInstance, robots: Sequence[str]) -> tuple[str, ...]:
    """The robots a request for ``label`` (absolute) is sent to, in team order."""
    named = {r.name for r in label.referents if isinstance(r, Entity) and r.robot}
    if label.is_fully_instantiated and named:
        return tuple(robot for robot in robots if robot in named)
    return tuple(robots)


def request_variants(label: InformationInstance, robot: str) -> tuple[InformationInstance, ...]:
    """What ``robot`` can provide for ``label``, in its local frame (footnote 9)."""
    local = to_local(label, robot)
    if local.has_local:
        return (local,)
    variables = local.variables
    if variables:
        variants = []
        for variable in variables:
            variant = local.substitute({variable: LOCAL})
            if not variant.is_degenerate:
                variants.append(variant)
        return tuple(variants)
    if all(isinstance(r, Entity) and not r.robot for r in local.referents):
        return (local,)
    return ()


def answers_request(instance: InformationInstance, label: InformationInstance) -> bool:
    """Whether ``instance`` is actual information (fully instantiated, distinct entities) of the
    requested ``label``."""
    return not instance.is_degenerate and bind_to_ground(label, instance, {}) is not None


@dataclass
class RequestLedger:
    """The Distinct Requests constraint for one robot: the labels it has requested."""

    robot: str
    sent: dict[InformationInstance, None] = field(default_factory=dict)
    suppressed: int = 0

    def already_requested(self, label: InformationInstance,
                          chain: Iterable[tuple[str, InformationInstance]] = ()) -> bool:
        label = canonical_instance(label)
        return label in self.sent or any(robot == self.robot and canonical_instance(earlier) == label
                                         for robot, earlier in chain)

    def admit(self, label: InformationInstance, chain: Iterable[tuple[str, InformationInstance]] = ()) -> bool:
        """Record a request for ``label``; False (a duplicate, not to be sent) if it was sent before."""
        if self.already_requested(label, chain):
            self.suppressed += 1
            return False
        self.sent[canonical_instance(label)] = None
        return True


__all__ = [
    'InformationRequest', 'RequestLedger', 'addressees', 'answers_request',
    'request_label', 'request_variants', 'to_absolute', 'to_local',
]

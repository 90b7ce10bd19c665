"""Messages of the agent-to-agent channel as core objects, and their strict codec (dict / JSON).

Algorithm 2 and Section V: agents send CS information requests, answer others' requests with
what they can provide, and set up the least-cost coalition by request-and-wait negotiation.
On the channel these are :class:`ChannelMessage` s of the kinds in :class:`MessageKind`:

=================  ============================================================================
REQUEST            an :class:`~..requests.InformationRequest` (requester = sender, label, chain)
OFFER              an :class:`OfferSummary`: the wire form of an :class:`~..coalition_solution.InformationOffer`
ACK                receipt of a REQUEST, OFFER or RELEASE (``in_reply_to``)
COMMIT_REQUEST     join coalition ``coalition_id`` (members, cost, hold time)
COMMIT_ACCEPT/     the answer to a COMMIT_REQUEST (it acknowledges it too)
COMMIT_REJECT
RELEASE            the leader frees a helper from ``coalition_id``
INFORMATION        a streamed value of an instance a helper provides to coalition ``coalition_id``
                   (``instance``, ``values``; not acknowledged: the latest value wins,
                   :mod:`..value_fields`)
=================  ============================================================================

An offer on the wire carries the provided instance, the helper coalition's cost and members,
not the helper's local coalition solution: that stays with the provider, which recognises the
offer by its message id when the requester negotiates (our choice; the paper does not say what
an answer carries beyond the information).

Dict form (``to_dict`` / :meth:`ChannelCodec.decode`): flat, with the common fields ``kind``
(lower case name), ``message_id``, ``sender``, ``receiver`` ('' = every robot),
``conversation_id``, ``in_reply_to`` and the fields of the kind (:data:`KIND_FIELDS`).
Labels are ``{'type': 'F_R', 'referents': ['X', 'robot_1']}`` and an INFORMATION message's
``values`` a list ``[{'name': 'x', 'value': 1.5}, ...]``, both as in the ROS message
(``Information``, ``NamedValue[]``).
Decoding checks everything a remote robot could get wrong -- an unknown kind, an unknown
information type (against the agent's schema library), a malformed or unknown referent, a
wrong arity, an unknown robot, a streamed value with an unknown, repeated, missing or
non-finite field (:func:`~..value_fields.check_value_fields`) -- and raises
:class:`~..errors.RequestError` (a ``ValueError``) whose message starts with the field path,
e.g. ``message.label.referents[1]: ...`` or ``message.values.x: must be a finite number``.
"""
from __future__ import annotations

import enum
import json
import math
from dataclasses import dataclass, field, replace
from typing import Any, Mapping, Sequence

from collab_tools.core.fields import type_name as describe_type

from ..errors import InformationError, RequestError
from ..information import (
    IDENTIFIER_PATTERN, VARIABLE_PATTERN, EntityCatalog, InformationInstance, InformationTypes, Variable,
    canonical_instance,
)
from ..value_fields import check_value_fields
from ..requests import InformationRequest

#: Largest message id (the ROS field is uint64).
MAX_MESSAGE_ID = 2 ** 64 - 1


class MessageKind(enum.IntEnum):
    """Kinds of channel messages; the values are the AgentMessage constants."""

    REQUEST = 1
    OFFER = 2
    ACK = 3
    COMMIT_REQUEST = 4
    COMMIT_ACCEPT = 5
    COMMIT_REJECT = 6
    RELEASE = 7
    INFORMATION = 8

    @property
    def text(self) -> str:
        return self.name.lower()


#: Kinds whose delivery the sender confirms (ACK, or COMMIT_ACCEPT/REJECT for COMMIT_REQUEST).
ACKNOWLEDGED_KINDS = frozenset({MessageKind.REQUEST, MessageKind.OFFER, MessageKind.COMMIT_REQUEST,
                                MessageKind.RELEASE})
#: Kinds that answer a COMMIT_REQUEST.
COMMIT_ANSWERS = frozenset({MessageKind.COMMIT_ACCEPT, MessageKind.COMMIT_REJECT})

COMMON_FIELDS = ('kind', 'message_id', 'sender', 'receiver', 'conversation_id', 'in_reply_to')
#: The payload fields of each kind (besides COMMON_FIELDS); every one is required.
KIND_FIELDS: dict[MessageKind, tuple[str, ...]] = {
    MessageKind.REQUEST: ('label', 'chain'),
    MessageKind.OFFER: ('label', 'instance', 'cost', 'members'),
    MessageKind.ACK: (),
    MessageKind.COMMIT_REQUEST: ('coalition_id', 'members', 'cost', 'hold_seconds'),
    MessageKind.COMMIT_ACCEPT: ('coalition_id',),
    MessageKind.COMMIT_REJECT: ('coalition_id', 'reason'),
    MessageKind.RELEASE: ('coalition_id', 'reason'),
    MessageKind.INFORMATION: ('instance', 'coalition_id', 'values'),
}
#: Kinds that must name what they answer.
REPLY_KINDS = frozenset({MessageKind.OFFER, MessageKind.ACK, MessageKind.COMMIT_ACCEPT, MessageKind.COMMIT_REJECT})


@dataclass(frozen=True)
class OfferSummary:
    """What an OFFER says: ``provider`` can provide ``instance`` (fully instantiated) for the
    requested ``request`` label through a coalition of ``members`` costing ``cost``."""

    provider: str
    request: InformationInstance
    instance: InformationInstance
    cost: float
    members: tuple[str, ...]


@dataclass(frozen=True)
class ChannelMessage:
    """One message of the agent channel. Payload fields unused by ``kind`` keep their defaults."""

    kind: MessageKind
    message_id: int
    sender: str
    receiver: str = ''
    conversation_id: int = 0
    in_reply_to: int = 0
    request: InformationRequest | None = None
    offer: OfferSummary | None = None
    coalition_id: str = ''
    members: tuple[str, ...] = ()
    cost: float = 0.0
    hold_seconds: float = 0.0
    reason: str = ''
    #: INFORMATION: the instance's value, (field, number) pairs in order (value_fields.VALUE_FIELDS)
    instance: InformationInstance | None = None
    values: tuple[tuple[str, float], ...] = ()

    def __str__(self) -> str:
        to = self.receiver or '*'
        detail = ''
        if self.request is not None:
            detail = f' {self.request.label}'
        elif self.offer is not None:
            detail = f' {self.offer.instance} (cost {self.offer.cost:g})'
        elif self.instance is not None:
            detail = f' {self.instance} = {dict(self.values)}'
        elif self.coalition_id:
            detail = f' {self.coalition_id}'
        reply = f' re {self.in_reply_to}' if self.in_reply_to else ''
        return f'{self.kind.text} #{self.message_id} {self.sender}->{to}{reply}{detail}'

    @property
    def needs_ack(self) -> bool:
        return self.kind in ACKNOWLEDGED_KINDS

    @property
    def key(self) -> tuple[str, int]:
        """What identifies the message across retries: (sender, message id)."""
        return (self.sender, self.message_id)

    def addressed_to(self, receiver: str) -> 'ChannelMessage':
        return replace(self, receiver=receiver)

    def to_dict(self) -> dict:
        data: dict[str, Any] = {'kind': self.kind.text, 'message_id': self.message_id, 'sender': self.sender,
                                'receiver': self.receiver, 'conversation_id': self.conversation_id,
                                'in_reply_to': self.in_reply_to}
        for name in KIND_FIELDS[self.kind]:
            if name == 'label':
                label = self.request.label if self.request is not None else self.offer.request  # type: ignore[union-attr]
                data['label'] = instance_to_dict(label)
            elif name == 'chain':
                data['chain'] = [{'requester': robot, 'label': instance_to_dict(label)}
                                 for robot, label in self.request.chain]  # type: ignore[union-attr]
            elif name == 'instance':
                instance = self.instance if self.kind is MessageKind.INFORMATION else self.offer.instance  # type: ignore[union-attr]
                data['instance'] = instance_to_dict(instance)  # type: ignore[arg-type]
            elif name == 'values':
                data['values'] = [{'name': name, 'value': number} for name, number in self.values]
            elif name == 'cost':
                data['cost'] = self.offer.cost if self.kind is MessageKind.OFFER else self.cost  # type: ignore[union-attr]
            elif name == 'members':
                data['members'] = list(self.offer.members if self.kind is MessageKind.OFFER  # type: ignore[union-attr]
                                       else self.members)
            else:
                data[name] = getattr(self, name)
        return data

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), sort_keys=True)


def instance_to_dict(instance: InformationInstance) -> dict:
    return {'type': instance.label, 'referents': [str(r) for r in instance.referents]}


@dataclass
class ChannelCodec:
    """Validates channel messages for one agent: information types from its schema library,
    entities = the library's objects + the team's robots."""

    types: InformationTypes
    catalog: EntityCatalog
    robots: tuple[str, ...] = field(init=False)
    #: (type, referents) -> the checked instance: the same few hundred instances come and go in
    #: every batch (only valid ones are kept; a malformed one is checked, and refused, each time)
    _checked: dict[tuple, InformationInstance] = field(init=False, default_factory=dict, repr=False)
    _canonical: dict[InformationInstance, InformationInstance] = field(init=False, default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        self.robots = tuple(sorted(self.catalog.robots))

    @classmethod
    def for_team(cls, library: Any, robots: Sequence[str]) -> 'ChannelCodec':
        """The codec of an agent with schema library ``library`` in a team of ``robots``."""
        return cls(library.types, library.catalog.with_robots(robots))

    # --- decoding -------------------------------------------------------------------------
    def from_json(self, text: Any) -> ChannelMessage:
        if isinstance(text, (bytes, bytearray)):
            try:
                text = text.decode('utf-8')
            except UnicodeDecodeError as exc:
                raise RequestError(f'message: not UTF-8 text ({exc})') from None
        if not isinstance(text, str):
            raise RequestError(f'message: must be JSON text (got {describe_type(text)})')
        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise RequestError(f'message: invalid JSON ({exc})') from None
        return self.decode(data)

    def decode(self, data: Any, path: str = 'message') -> ChannelMessage:
        """A validated :class:`ChannelMessage` from its dict form (see the module docstring)."""
        if not isinstance(data, Mapping):
            raise RequestError(f'{path}: must be a mapping (got {describe_type(data)})')
        kind = self._kind(data.get('kind', None), f'{path}.kind')
        allowed = COMMON_FIELDS + KIND_FIELDS[kind]
        for key in data:
            if key not in allowed:
                raise RequestError(f'{path}.{key}: unknown field for a {kind.text} message '
                                   f'(allowed: {", ".join(allowed)})')
        for key in allowed:
            if key not in data:
                raise RequestError(f'{path}.{key}: missing required field of a {kind.text} message')
        message_id = self._message_id(data['message_id'], f'{path}.message_id', zero=False)
        sender = self._robot(data['sender'], f'{path}.sender')
        receiver = data['receiver']
        if receiver != '':
            receiver = self._robot(receiver, f'{path}.receiver', hint=" or '' for every robot")
        conversation_id = self._message_id(data['conversation_id'], f'{path}.conversation_id', zero=True)
        in_reply_to = self._message_id(data['in_reply_to'], f'{path}.in_reply_to', zero=True)
        if kind in REPLY_KINDS and in_reply_to == 0:
            raise RequestError(f'{path}.in_reply_to: a {kind.text} message must name the message it answers (got 0)')
        if kind in REPLY_KINDS and receiver == '':
            raise RequestError(f"{path}.receiver: a {kind.text} message goes to one robot (got '')")
        fields: dict[str, Any] = {}
        if kind is MessageKind.REQUEST:
            label = self._label(data['label'], f'{path}.label')
            chain = self._chain(data['chain'], f'{path}.chain')
            fields['request'] = InformationRequest(sender, label, chain)
        elif kind is MessageKind.OFFER:
            requested = self._label(data['label'], f'{path}.label')
            instance = self._instance(data['instance'], f'{path}.instance')
            if not instance.is_fully_instantiated:
                raise RequestError(f'{path}.instance: an offer provides actual information, with every referent '
                                   f'instantiated (got {instance})')
            if instance.label != requested.label:
                raise RequestError(f'{path}.instance: type {instance.label} does not answer the requested '
                                   f'{requested} (type {requested.label})')
            members = self._members(data['members'], f'{path}.members')
            if sender not in members:
                raise RequestError(f'{path}.members: the provider {sender} must be a member of its coalition '
                                   f'(got {list(members)})')
            fields['offer'] = OfferSummary(sender, requested, instance, self._cost(data['cost'], f'{path}.cost'),
                                           members)
        elif kind is MessageKind.COMMIT_REQUEST:
            fields['members'] = self._members(data['members'], f'{path}.members')
            if sender not in fields['members']:
                raise RequestError(f'{path}.members: the leader {sender} must be a member of the coalition '
                                   f'(got {list(fields["members"])})')
            fields['cost'] = self._cost(data['cost'], f'{path}.cost')
            fields['hold_seconds'] = self._cost(data['hold_seconds'], f'{path}.hold_seconds')
        elif kind is MessageKind.INFORMATION:
            if receiver == '':
                raise RequestError(f"{path}.receiver: an information message goes to one robot (got '')")
            instance = self._instance(data['instance'], f'{path}.instance')
            if not instance.is_fully_instantiated:
                raise RequestError(f'{path}.instance: streamed information has every referent instantiated '
                                   f'(got {instance})')
            fields['instance'] = instance
            fields['values'] = self._values(instance.label, data['values'], f'{path}.values')
        if 'coalition_id' in data:
            fields['coalition_id'] = self._coalition_id(data['coalition_id'], f'{path}.coalition_id')
        if 'reason' in data:
            if not isinstance(data['reason'], str):
                raise RequestError(f'{path}.reason: must be a string (got {describe_type(data["reason"])})')
            fields['reason'] = data['reason']
        return ChannelMessage(kind, message_id, sender, receiver, conversation_id, in_reply_to, **fields)

    # --- field readers ----------------------------------------------------------------------
    @staticmethod
    def _kind(value: Any, path: str) -> MessageKind:
        names = ', '.join(kind.text for kind in MessageKind)
        if isinstance(value, str):
            try:
                return MessageKind[value.upper()]
            except KeyError:
                pass
        elif isinstance(value, int) and not isinstance(value, bool):
            try:
                return MessageKind(value)
            except ValueError:
                pass
        raise RequestError(f'{path}: unknown message kind {value!r} (allowed: {names}, or 1-{len(MessageKind)})')

    @staticmethod
    def _message_id(value: Any, path: str, *, zero: bool) -> int:
        lowest = 0 if zero else 1
        if isinstance(value, bool) or not isinstance(value, int) or not lowest <= value <= MAX_MESSAGE_ID:
            raise RequestError(f'{path}: must be an integer in [{lowest}, 2^64 - 1] (got {describe_type(value)} {value!r})')
        return value

    def _robot(self, value: Any, path: str, hint: str = '') -> str:
        if not isinstance(value, str) or value not in self.catalog.robots:
            raise RequestError(f"{path}: unknown robot {value!r} (team: {', '.join(self.robots) or 'none'}{hint})")
        return value

    def _members(self, value: Any, path: str) -> tuple[str, ...]:
        if not isinstance(value, (list, tuple)) or not value:
            raise RequestError(f'{path}: must be a non-empty list of robot names (got {describe_type(value)} {value!r})')
        members = tuple(self._robot(robot, f'{path}[{index}]') for index, robot in enumerate(value))
        if len(set(members)) != len(members):
            raise RequestError(f'{path}: a robot is listed twice (got {list(members)})')
        return members

    @staticmethod
    def _cost(value: Any, path: str) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0:
            raise RequestError(f'{path}: must be a finite number >= 0 (got {describe_type(value)} {value!r})')
        return float(value)

    @staticmethod
    def _coalition_id(value: Any, path: str) -> str:
        if not isinstance(value, str) or not value.strip():
            raise RequestError(f'{path}: must be a non-empty string (got {describe_type(value)} {value!r})')
        return value

    def _instance(self, value: Any, path: str) -> InformationInstance:
        """An information instance from {'type', 'referents'}; 'local' is not allowed on the wire."""
        if not isinstance(value, Mapping):
            raise RequestError(f"{path}: must be a mapping with type and referents (got {describe_type(value)})")
        unknown = sorted(str(key) for key in value if key not in ('type', 'referents'))
        if unknown:
            raise RequestError(f'{path}.{unknown[0]}: unknown field (allowed: type, referents)')
        label = value.get('type')
        referents = value.get('referents', None)
        key = None
        if (isinstance(label, str) and isinstance(referents, (list, tuple))
                and all(isinstance(name, str) for name in referents)):
            key = (label, tuple(referents))
            known = self._checked.get(key)
            if known is not None:
                return known
        if not isinstance(label, str) or label not in self.types:
            raise RequestError(f"{path}.type: unknown information type {label!r} "
                               f"(known: {', '.join(self.types.labels) or 'none'})")
        if not isinstance(referents, (list, tuple)):
            raise RequestError(f'{path}.referents: must be a list of names (got {describe_type(referents)})')
        parsed = []
        for index, name in enumerate(referents):
            where = f'{path}.referents[{index}]'
            if not isinstance(name, str) or not IDENTIFIER_PATTERN.match(name):
                raise RequestError(f'{where}: malformed referent {name!r} (a robot or object name, or a variable '
                                   f'such as X or Z1)')
            if VARIABLE_PATTERN.match(name):
                parsed.append(Variable(name))
                continue
            if name == 'local':
                raise RequestError(f"{where}: messages name robots, not 'local'")
            try:
                parsed.append(self.catalog.entity(name))
            except InformationError as exc:
                raise RequestError(f'{where}: {exc}') from None
        instance = InformationInstance(label, tuple(parsed))
        try:
            self.types.check(instance)
        except InformationError as exc:
            raise RequestError(f'{path}.referents: {exc}') from None
        if instance.is_degenerate:
            raise RequestError(f'{path}.referents: an entity appears twice in {instance} (referents of one '
                               f'instance are different entities)')
        if key is not None:
            self._checked[key] = instance
        return instance

    @staticmethod
    def _values(label: str, value: Any, path: str) -> tuple[tuple[str, float], ...]:
        """A streamed value of a ``label`` instance from its list of {name, value} entries."""
        if not isinstance(value, (list, tuple)):
            raise RequestError(f'{path}: must be a list of {{name, value}} entries (got {describe_type(value)})')
        pairs = []
        for index, entry in enumerate(value):
            if not isinstance(entry, Mapping) or set(entry) != {'name', 'value'}:
                raise RequestError(f'{path}[{index}]: must be a mapping with name and value (got {entry!r})')
            pairs.append((entry['name'], entry['value']))
        return tuple(check_value_fields(label, pairs, path).items())

    def _label(self, value: Any, path: str) -> InformationInstance:
        instance = self._instance(value, path)
        label = self._canonical.get(instance)
        if label is None:
            label = self._canonical[instance] = canonical_instance(instance)
        return label

    def _chain(self, value: Any, path: str) -> tuple[tuple[str, InformationInstance], ...]:
        if not isinstance(value, (list, tuple)):
            raise RequestError(f'{path}: must be a list (got {describe_type(value)})')
        chain = []
        for index, entry in enumerate(value):
            where = f'{path}[{index}]'
            if not isinstance(entry, Mapping) or set(entry) != {'requester', 'label'}:
                raise RequestError(f'{where}: must be a mapping with requester and label (got {entry!r})')
            chain.append((self._robot(entry['requester'], f'{where}.requester'),
                          self._label(entry['label'], f'{where}.label')))
        return tuple(chain)

    # --- building messages ------------------------------------------------------------------
    def check_outgoing(self, message: ChannelMessage) -> ChannelMessage:
        """Round-trip ``message`` through the codec: an agent never sends what a peer would reject."""
        return self.decode(message.to_dict(), path=f'outgoing {message.kind.text} message')


def request_message(request: InformationRequest, message_id: int, receiver: str = '') -> ChannelMessage:
    """A REQUEST; its conversation is itself."""
    return ChannelMessage(MessageKind.REQUEST, message_id, request.requester, receiver,
                          conversation_id=message_id, request=request)


def offer_message(offer: OfferSummary, message_id: int, request: ChannelMessage) -> ChannelMessage:
    """An OFFER answering the REQUEST ``request``."""
    return ChannelMessage(MessageKind.OFFER, message_id, offer.provider, request.sender,
                          conversation_id=request.conversation_id or request.message_id,
                          in_reply_to=request.message_id, offer=offer)


def commit_request_message(leader: str, message_id: int, receiver: str, coalition_id: str,
                           members: Sequence[str], cost: float, hold_seconds: float) -> ChannelMessage:
    return ChannelMessage(MessageKind.COMMIT_REQUEST, message_id, leader, receiver, coalition_id=coalition_id,
                          members=tuple(members), cost=cost, hold_seconds=hold_seconds)


def release_message(leader: str, message_id: int, receiver: str, coalition_id: str, reason: str = '') -> ChannelMessage:
    return ChannelMessage(MessageKind.RELEASE, message_id, leader, receiver, coalition_id=coalition_id, reason=reason)


def information_message(sender: str, message_id: int, receiver: str, coalition_id: str,
                        instance: InformationInstance, values: Mapping[str, float]) -> ChannelMessage:
    """A streamed value of ``instance`` for ``receiver`` in coalition ``coalition_id``."""
    return ChannelMessage(MessageKind.INFORMATION, message_id, sender, receiver, coalition_id=coalition_id,
                          instance=instance, values=tuple((name, float(v)) for name, v in values.items()))


def reply_message(kind: MessageKind, message_id: int, sender: str, to: ChannelMessage, *,
                  coalition_id: str = '', reason: str = '') -> ChannelMessage:
    """An ACK, COMMIT_ACCEPT or COMMIT_REJECT answering ``to``."""
    return ChannelMessage(kind, message_id, sender, to.sender, conversation_id=to.conversation_id,
                          in_reply_to=to.message_id, coalition_id=coalition_id, reason=reason)


__all__ = [
    'ACKNOWLEDGED_KINDS', 'COMMIT_ANSWERS', 'COMMON_FIELDS', 'KIND_FIELDS', 'MAX_MESSAGE_ID', 'ChannelCodec',
    'ChannelMessage', 'MessageKind', 'OfferSummary', 'commit_request_message', 'information_message', 'instance_to_dict',
    'offer_message', 'release_message', 'reply_message', 'request_message',
]

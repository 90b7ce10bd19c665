"""The live view's behaviour without ROS: which topics go to Foxglove, their channels and schemas.

The live_view node (``collab_tools.live_view_node``) runs a Foxglove WebSocket server
(``foxglove-sdk``) and forwards the run's ROS topics as they are: the serialized CDR of a raw
subscription, on a channel whose schema is the type's ``ros2msg`` definition exactly as the bag
recorder writes it into an MCAP file (:func:`.bag_types.message_definition` over a typestore from
:func:`.bag_types.build_typestore`), so the Foxglove app decodes both the same way.

As foxglove_bridge does, every discovered topic is *advertised* at once but *subscribed* in ROS only
while a Foxglove client subscribes to its channel: an unwatched camera is not rendered for the
viewer (the bridge renders only for subscribers) and nothing is deserialised or copied for nobody.
:class:`LiveChannels` keeps that bookkeeping; the server's callbacks arrive on its own thread, so
client subscriptions are queued (thread safe) and the node applies them on its executor.
"""
from __future__ import annotations

import ipaddress
import re
import threading
from collections.abc import Iterable
from dataclasses import dataclass, field

from .bag_types import build_typestore, message_definition, normalize_type_name
from .settings import Setting, SettingsSchema
from .tool_settings import DEFAULT_EXCLUDE, regex_problem

#: Foxglove's names for a ROS 2 channel: schema encoding and message encoding.
SCHEMA_ENCODING = 'ros2msg'
MESSAGE_ENCODING = 'cdr'
DEFAULT_HOST = '127.0.0.1'
DEFAULT_PORT = 8765


def host_problem(host: str) -> str | None:
    """Why ``host`` is no address to bind to (None when it is an IP address or 'localhost')."""
    if host == 'localhost':
        return None
    try:
        ipaddress.ip_address(host)
    except ValueError:
        return f'must be an IP address to bind to, e.g. 127.0.0.1 or 0.0.0.0 (got {host!r})'
    return None


LIVE_VIEW_SETTINGS = SettingsSchema(
    Setting('host', DEFAULT_HOST, 'bind address of the Foxglove WebSocket server (127.0.0.1: this machine '
            'only; 0.0.0.0: every interface, anyone on the network can watch)', check=host_problem),
    Setting('port', DEFAULT_PORT, 'TCP port of the WebSocket server; 0 = any free port (logged)',
            low=0, high=65535),
    Setting('topics', [''], "topics to forward; a relative name is resolved in this node's namespace; "
            "[''] = every topic that exclude does not match"),
    Setting('exclude', DEFAULT_EXCLUDE, 'regular expressions (full match on absolute names) of the topics '
            'not forwarded when topics is empty', check=regex_problem),
    Setting('discovery_period', 1.0, 'seconds (wall clock) between looks for new and vanished topics',
            low=0.05, high=60.0, dynamic=True),
    Setting('queue_depth', 10, "depth of a forwarded topic's subscription queue", low=1, high=10000),
    Setting('server_name', 'hetero_collab', 'server name shown by the Foxglove app'),
)


@dataclass(frozen=True)
class TopicSelection:
    """Which topics are forwarded: the listed ones, or every one no exclude pattern matches."""

    topics: tuple[str, ...] = ()
    exclude: tuple[str, ...] = tuple(DEFAULT_EXCLUDE)
    _patterns: tuple = field(default=(), init=False, repr=False, compare=False)

    def __post_init__(self):
        object.__setattr__(self, 'topics', tuple(t for t in self.topics if t))
        object.__setattr__(self, '_patterns', tuple(re.compile(p) for p in self.exclude if p))

    def wanted(self, topic: str) -> bool:
        if self.topics:
            return topic in self.topics
        return not any(pattern.fullmatch(topic) for pattern in self._patterns)


class SchemaBook:
    """ros2msg schemas of message types, built as the bag recorder builds its MCAP schemas."""

    def __init__(self, prefixes: Iterable[str] | None = None):
        self._prefixes = prefixes
        self._types: set[str] = set()
        self._store = None
        self._definitions: dict[str, str] = {}

    def schema(self, type_name: str) -> tuple[str, bytes]:
        """(schema name ``pkg/msg/Name``, definition bytes); UnknownMessageTypeError or ValueError."""
        name = normalize_type_name(type_name)
        if name not in self._definitions:
            if self._store is None or name not in self._store.fielddefs:
                self._store = build_typestore(self._types | {name}, self._prefixes)
            self._types.add(name)
            self._definitions[name] = message_definition(self._store, name)
        return name, self._definitions[name].encode('utf-8')


@dataclass
class LiveTopic:
    topic: str
    type_name: str
    channel: object            # the server's channel (opaque here)
    channel_id: int
    clients: set = field(default_factory=set)
    subscribed: bool = False   # a ROS subscription exists


class LiveChannels:
    """Advertised topics and who watches them; thread safe (the server calls from its own thread).

    ``client_subscribed``/``client_unsubscribed`` come from the server; :meth:`pending` tells the
    node which ROS subscriptions to create (``'subscribe'``) or destroy (``'unsubscribe'``) now.
    """

    def __init__(self):
        self._lock = threading.Lock()
        self._by_topic: dict[str, LiveTopic] = {}
        self._by_channel: dict[int, LiveTopic] = {}
        self.failures: dict[str, str] = {}

    def advertised(self, topic: str) -> LiveTopic | None:
        with self._lock:
            return self._by_topic.get(topic)

    def topics(self) -> dict[str, str]:
        with self._lock:
            return {t.topic: t.type_name for t in self._by_topic.values()}

    def add(self, topic: str, type_name: str, channel, channel_id: int) -> LiveTopic:
        with self._lock:
            if topic in self._by_topic:
                raise ValueError(f'topic {topic} is already advertised')
            entry = LiveTopic(topic, type_name, channel, int(channel_id))
            self._by_topic[topic] = entry
            self._by_channel[entry.channel_id] = entry
            return entry

    def remove(self, topic: str) -> LiveTopic | None:
        with self._lock:
            entry = self._by_topic.pop(topic, None)
            if entry is not None:
                self._by_channel.pop(entry.channel_id, None)
            return entry

    def client_subscribed(self, client_id: int, channel_id: int) -> None:
        with self._lock:
            entry = self._by_channel.get(int(channel_id))
            if entry is not None:
                entry.clients.add(int(client_id))

    def client_unsubscribed(self, client_id: int, channel_id: int) -> None:
        with self._lock:
            entry = self._by_channel.get(int(channel_id))
            if entry is not None:
                entry.clients.discard(int(client_id))

    def pending(self) -> list[tuple[str, LiveTopic]]:
        """('subscribe' | 'unsubscribe', topic) for every topic whose ROS side must change."""
        with self._lock:
            changes = []
            for entry in self._by_topic.values():
                if entry.clients and not entry.subscribed:
                    changes.append(('subscribe', entry))
                elif not entry.clients and entry.subscribed:
                    changes.append(('unsubscribe', entry))
            return changes

    def vanished(self, present: Iterable[str]) -> list[LiveTopic]:
        """Advertised topics not among ``present`` (their publishers are gone)."""
        present = set(present)
        with self._lock:
            return [e for t, e in self._by_topic.items() if t not in present]


def connect_hint(host: str, port: int) -> str:
    """How a user connects the Foxglove app to the server."""
    shown = '127.0.0.1' if host in ('0.0.0.0', '::') else host
    return (f'live view: open the Foxglove app -> Open connection -> Foxglove WebSocket -> '
            f'ws://{shown}:{port} (layouts: config/foxglove/)')

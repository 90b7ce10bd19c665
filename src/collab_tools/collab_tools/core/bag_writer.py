"""rosbag2 (metadata version 9, MCAP) writer for raw CDR messages, without rclpy.

Built on :class:`rosbags.rosbag2.Writer`, writing what rosbag2 Jazzy's MCAP storage writes:
the MCAP file carries each type's ROS 2 message definition as a ``ros2msg`` schema
(:func:`~.bag_types.message_definition`, which also covers an action's generated messages)
and, per channel, ``offered_qos_profiles`` (rosbag2's YAML list) and ``topic_type_hash``
(the RIHS01 type hash); metadata.yaml and the MCAP's ``rosbag2`` metadata record have
rosbag2's keys in its order, ``version: 9`` and ``ros_distro`` (``jazzy``, not rosbags'
own ``rosbags``), so ``ros2 bag info`` / ``ros2 bag play`` of a Jazzy install accept the bag.

Chunk compression follows rosbag2's MCAP storage presets (``storage_preset_profile``):

* ``none``: uncompressed chunks of 768 KiB (mcap's default chunk size; rosbag2's default).
* ``fastwrite``: rosbag2 writes no chunks; rosbags' writer always chunks, so this is ``none``.
* ``zstd_fast``: zstd at mcap's "Fastest" level (-5) per 768 KiB chunk.
* ``zstd_small``: zstd at mcap's "Slowest" level (19) per 4 MiB chunk: the smallest file,
  and the most CPU, spent in the recorder's thread when a chunk closes.

metadata.yaml says ``compression_mode: ''`` for all of them, as rosbag2 does: chunk
compression is the storage's, readers decompress it transparently.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Sequence
from contextlib import suppress
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from rosbags.interfaces import (
    Connection,
    Qos,
    QosDurability,
    QosHistory,
    QosLiveliness,
    QosReliability,
    QosTime,
)
from rosbags.rosbag2 import StoragePlugin
from rosbags.typesys.store import Typestore

from .bag_storage import (BAG_VERSION, ROS_DISTRO, STORAGE_PRESETS, TYPE_HASH, Rosbag2Writer, StoragePreset,
                          qos_profiles_text)
from .bag_types import message_definition, normalize_type_name

__all__ = [
    'BAG_VERSION',
    'DURATION_INFINITE_NS',
    'ROS_DISTRO',
    'STORAGE_PRESETS',
    'TYPE_HASH',
    'BagWriter',
    'QosSpec',
    'StoragePreset',
    'qos_profiles_text',
]

#: rmw's RMW_DURATION_INFINITE in nanoseconds (INT64_MAX); rosbag2 >= v9 stores it as
#: {sec: 9223372036, nsec: 854775807}.
DURATION_INFINITE_NS = 2**63 - 1
_INFINITE_TIME = QosTime(DURATION_INFINITE_NS // 1_000_000_000, DURATION_INFINITE_NS % 1_000_000_000)
# What older rmw implementations (and rosbag2 metadata < v9) used for "infinite".
_LEGACY_INFINITE = {(0x7FFFFFFF, 0xFFFFFFFF), (0x7FFFFFFF, 0x7FFFFFFF)}

_HISTORY = {
    'keep_last': QosHistory.KEEP_LAST,
    'keep_all': QosHistory.KEEP_ALL,
    'system_default': QosHistory.SYSTEM_DEFAULT,
    'unknown': QosHistory.UNKNOWN,
}
_RELIABILITY = {
    'reliable': QosReliability.RELIABLE,
    'best_effort': QosReliability.BEST_EFFORT,
    'system_default': QosReliability.SYSTEM_DEFAULT,
    'unknown': QosReliability.UNKNOWN,
    'best_available': QosReliability.BEST_AVAILABLE,
}
_DURABILITY = {
    'volatile': QosDurability.VOLATILE,
    'transient_local': QosDurability.TRANSIENT_LOCAL,
    'system_default': QosDurability.SYSTEM_DEFAULT,
    'unknown': QosDurability.UNKNOWN,
    'best_available': QosDurability.BEST_AVAILABLE,
}
_LIVELINESS = {
    'automatic': QosLiveliness.AUTOMATIC,
    'manual_by_topic': QosLiveliness.MANUAL_BY_TOPIC,
    'manual_by_node': QosLiveliness.MANUAL_BY_NODE,  # deprecated in ROS 2, still representable
    'system_default': QosLiveliness.SYSTEM_DEFAULT,
    'unknown': QosLiveliness.UNKNOWN,
    'best_available': QosLiveliness.BEST_AVAILABLE,
}

_STORAGE = {'mcap': StoragePlugin.MCAP, 'sqlite3': StoragePlugin.SQLITE3}


def _policy_name(value: Any) -> Any:
    """Accept 'keep_last', 'KEEP_LAST', or an enum member (rclpy or rosbags) by name."""
    name = getattr(value, 'name', value)
    return name.lower() if isinstance(name, str) else name


def _duration_ns(value: Any) -> Any:
    """Accept int ns, or a duration object with ``.nanoseconds`` (rclpy) or ``sec``/``nsec``."""
    if isinstance(value, bool):
        return value
    if hasattr(value, 'nanoseconds'):
        return value.nanoseconds
    if hasattr(value, 'sec') and hasattr(value, 'nsec'):
        sec, nsec = int(value.sec), int(value.nsec)
        if (sec, nsec) in _LEGACY_INFINITE or (sec, nsec) == tuple(_INFINITE_TIME):
            return DURATION_INFINITE_NS
        return sec * 1_000_000_000 + nsec
    return value


def _to_time(ns: int) -> QosTime:
    if ns == 0 or ns >= DURATION_INFINITE_NS:
        return _INFINITE_TIME
    return QosTime(ns // 1_000_000_000, ns % 1_000_000_000)


@dataclass(frozen=True)
class QosSpec:
    """One offered QoS profile, as recorded in the bag's metadata.

    Durations are nanoseconds; 0 (rmw's "default") and anything at or above
    INT64_MAX mean infinite and are stored as rosbag2's infinite value.
    Invalid values raise ValueError naming the field.
    """

    history: str
    depth: int
    reliability: str
    durability: str
    deadline_ns: int = 0
    lifespan_ns: int = 0
    liveliness: str = 'automatic'
    liveliness_lease_duration_ns: int = 0
    avoid_ros_namespace_conventions: bool = False

    def __post_init__(self) -> None:
        for field, table in (
            ('history', _HISTORY),
            ('reliability', _RELIABILITY),
            ('durability', _DURABILITY),
            ('liveliness', _LIVELINESS),
        ):
            value = _policy_name(getattr(self, field))
            if not isinstance(value, str) or value not in table:
                raise ValueError(
                    f'QosSpec.{field}: invalid value {getattr(self, field)!r}; '
                    f'expected one of {sorted(table)}'
                )
            object.__setattr__(self, field, value)
        if isinstance(self.depth, bool) or not isinstance(self.depth, int) or self.depth < 0:
            raise ValueError(f'QosSpec.depth: expected an int >= 0, got {self.depth!r}')
        for field in ('deadline_ns', 'lifespan_ns', 'liveliness_lease_duration_ns'):
            value = _duration_ns(getattr(self, field))
            if isinstance(value, bool) or not isinstance(value, int) or value < 0:
                raise ValueError(
                    f'QosSpec.{field}: expected nanoseconds as an int >= 0, got {getattr(self, field)!r}'
                )
            object.__setattr__(self, field, min(value, DURATION_INFINITE_NS))
        if not isinstance(self.avoid_ros_namespace_conventions, bool):
            raise ValueError(
                'QosSpec.avoid_ros_namespace_conventions: expected a bool, '
                f'got {self.avoid_ros_namespace_conventions!r}'
            )

    # ---- conversions -------------------------------------------------
    def to_rosbags(self) -> Qos:
        """The rosbags :class:`~rosbags.interfaces.Qos` for this profile."""
        return Qos(
            _HISTORY[self.history],
            self.depth,
            _RELIABILITY[self.reliability],
            _DURABILITY[self.durability],
            _to_time(self.deadline_ns),
            _to_time(self.lifespan_ns),
            _LIVELINESS[self.liveliness],
            _to_time(self.liveliness_lease_duration_ns),
            self.avoid_ros_namespace_conventions,
        )

    @classmethod
    def from_profile(cls, profile: Any) -> QosSpec:
        """From anything shaped like an ``rclpy.qos.QoSProfile`` (duck typed, no rclpy import).

        Policies may be enums (their ``name`` is used) or strings; durations
        may be objects with ``.nanoseconds`` (rclpy Duration), ``sec``/``nsec``, or ints.
        """
        return cls(
            history=_policy_name(profile.history),
            depth=int(profile.depth),
            reliability=_policy_name(profile.reliability),
            durability=_policy_name(profile.durability),
            deadline_ns=_duration_ns(getattr(profile, 'deadline', 0)),
            lifespan_ns=_duration_ns(getattr(profile, 'lifespan', 0)),
            liveliness=_policy_name(getattr(profile, 'liveliness', 'automatic')),
            liveliness_lease_duration_ns=_duration_ns(getattr(profile, 'liveliness_lease_duration', 0)),
            avoid_ros_namespace_conventions=bool(getattr(profile, 'avoid_ros_namespace_conventions', False)),
        )

    @classmethod
    def from_rosbags(cls, qos: Qos) -> QosSpec:
        """From a rosbags Qos (e.g. one read back from a bag)."""
        return cls(
            history=qos.history.name.lower(),
            depth=qos.depth,
            reliability=qos.reliability.name.lower(),
            durability=qos.durability.name.lower(),
            deadline_ns=_duration_ns(qos.deadline),
            lifespan_ns=_duration_ns(qos.lifespan),
            liveliness=qos.liveliness.name.lower(),
            liveliness_lease_duration_ns=_duration_ns(qos.liveliness_lease_duration),
            avoid_ros_namespace_conventions=bool(qos.avoid_ros_namespace_conventions),
        )


class BagWriter:
    """Write raw CDR messages into a new rosbag2 bag (version 9, as rosbag2 Jazzy writes it).

    The bag directory is created at construction; call :meth:`close` (or use
    ``with``) to write the index and metadata.yaml.  Thread safe.
    ``storage_preset``: one of :data:`STORAGE_PRESETS` (MCAP only; see the module docstring).
    ``ros_distro``: what metadata.yaml says recorded the bag.
    """

    def __init__(self, path: str | Path, typestore: Typestore, *, storage: str = 'mcap',
                 storage_preset: str = 'none', ros_distro: str = ROS_DISTRO) -> None:
        self.path = Path(path)
        if storage not in _STORAGE:
            raise ValueError(f'BagWriter storage: {storage!r} is not one of {sorted(_STORAGE)}')
        if storage_preset not in STORAGE_PRESETS:
            raise ValueError(f'BagWriter storage_preset: {storage_preset!r} is not one of '
                             f'{", ".join(STORAGE_PRESETS)}')
        if storage != 'mcap' and storage_preset != 'none':
            raise ValueError(f"BagWriter storage_preset: {storage_preset!r} is an MCAP preset (storage is {storage!r})")
        if not isinstance(ros_distro, str) or not ros_distro:
            raise ValueError(f'BagWriter ros_distro: expected a distribution name, got {ros_distro!r}')
        if self.path.exists():
            raise FileExistsError(f'bag path {self.path} already exists; BagWriter only creates new bags')
        self.storage = storage
        self.storage_preset = storage_preset
        self.typestore = typestore
        self._lock = threading.Lock()
        self._writer = Rosbag2Writer(self.path, _STORAGE[storage], STORAGE_PRESETS[storage_preset], ros_distro)
        self._writer.open()
        self._connections: dict[str, Connection] = {}
        self._types: dict[str, str] = {}
        self._counts: dict[str, int] = {}
        self._closed = False
        self._pending_since: float | None = None  # monotonic time of the pending chunk's first message

    # ---- topics ------------------------------------------------------
    def add_topic(self, topic: str, type_name: str, offered_qos: Sequence[QosSpec] = (),
                  type_hash: str | None = None) -> None:
        """Register ``topic`` with ``type_name`` (idempotent for the same pair).

        ``type_hash``: the RIHS01 hash the publishers report (rclpy's ``topic_type_hash``);
        it must equal the hash of the typestore's definition, which is otherwise used.
        Raises ValueError for a second type on the same topic, a type the typestore does
        not know, or a definition whose hash differs from the publishers' (the bag's schema
        would not describe their data).
        """
        type_name = normalize_type_name(type_name)
        with self._lock:
            self._check_open()
            have = self._types.get(topic)
            if have is not None:
                if have != type_name:
                    raise ValueError(
                        f'topic {topic!r} is already recorded with type {have!r}; cannot add it as {type_name!r}'
                    )
                return
            if type_name not in self.typestore.fielddefs:
                raise ValueError(
                    f'topic {topic!r}: type {type_name!r} is not in the typestore '
                    '(build it with build_typestore([...]) including this type)'
                )
            own_hash = self.typestore.hash_rihs01(type_name)
            if type_hash is not None and type_hash != own_hash:
                if not isinstance(type_hash, str) or not TYPE_HASH.match(type_hash):
                    raise ValueError(f'topic {topic!r}: type hash {type_hash!r} is not RIHS01_ and 64 hex digits')
                raise ValueError(
                    f'topic {topic!r}: the publishers\' {type_name} has type hash {type_hash}, the definition '
                    f'found for it has {own_hash} (the installed definition differs from the publishers\')')
            qos = [q if isinstance(q, QosSpec) else QosSpec.from_profile(q) for q in offered_qos]
            self._connections[topic] = self._writer.add_connection(
                topic,
                type_name,
                msgdef=message_definition(self.typestore, type_name),
                rihs01=own_hash,
                serialization_format='cdr',
                offered_qos_profiles=[q.to_rosbags() for q in qos],
            )
            self._types[topic] = type_name
            self._counts[topic] = 0

    def set_custom_data(self, key: str, value: str) -> None:
        """A ``custom_data`` entry of metadata.yaml (rosbag2's free key/value strings)."""
        with self._lock:
            self._check_open()
            self._writer.set_custom_data(key, value)

    def has_topic(self, topic: str) -> bool:
        return topic in self._types

    def topics(self) -> dict[str, str]:
        """Registered topics -> type names."""
        return dict(self._types)

    # ---- messages ----------------------------------------------------
    def write(self, topic: str, timestamp_ns: int, data: bytes) -> None:
        """Append one raw CDR message (as from a raw subscription) at ``timestamp_ns``."""
        with self._lock:
            self._check_open()
            connection = self._connections.get(topic)
            if connection is None:
                raise KeyError(f'topic {topic!r} was not added to the bag (call add_topic first)')
            self._writer.write(connection, int(timestamp_ns), bytes(data))
            self._counts[topic] += 1
            pending = self.storage == 'mcap' and bool(self._writer.storage.chunk.msgs)
            if not pending:
                self._pending_since = None  # this message closed the chunk (size reached)
            elif self._pending_since is None:
                self._pending_since = time.monotonic()

    def flush(self, max_age_s: float = 0.0) -> bool:
        """Write the chunk being filled if its first message is ``max_age_s`` old or older.

        Chunks close at the preset's size; a recorder calls this periodically so that a slow
        topic's messages reach the file too: a killed recorder then loses at most the chunk it
        was filling (:mod:`.bag_repair` makes the rest readable). True if a chunk was written.
        """
        with self._lock:
            if self._closed or self._pending_since is None:
                return False
            if time.monotonic() - self._pending_since < max_age_s:
                return False
            self._pending_since = None
            return self._writer.close_pending_chunk()

    def counts(self) -> dict[str, int]:
        """Messages written so far per topic."""
        with self._lock:
            return dict(self._counts)

    @property
    def closed(self) -> bool:
        return self._closed

    def close(self) -> None:
        """Finish the bag (index + metadata.yaml). Safe to call more than once."""
        with self._lock:
            if self._closed:
                return
            self._closed = True
            try:
                self._writer.close()
            except BaseException:
                with suppress(Exception):
                    self._writer.abort()
                raise

    def _check_open(self) -> None:
        if self._closed:
            raise RuntimeError(f'bag {self.path} is already closed')

    def __enter__(self) -> BagWriter:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        # Keep what was recorded even when the with-body failed.
        self.close()

    def __del__(self) -> None:  # pragma: no cover - best effort only
        with suppress(Exception):
            if not self._closed:
                self.close()

"""The rosbag2 Jazzy flavour of rosbags' writer: what bag_writer.BagWriter writes through.

rosbag2_storage_mcap (create_topic) stores per channel ``offered_qos_profiles`` (rosbag2's
YAML list of profiles with v9 policy names) and ``topic_type_hash`` (RIHS01); rosbag2's
metadata (metadata.yaml and the MCAP ``rosbag2`` metadata record) lists its keys in its own
order and names the distribution in ``ros_distro``. rosbags writes neither the type hash
per channel nor a distribution other than ``rosbags``: the subclasses here add both.
The storage presets and their mapping are described in bag_writer's docstring.
"""

from __future__ import annotations

import functools
import re
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from io import BytesIO
from pathlib import Path
from typing import Any

import yaml
from rosbags.interfaces import Connection, Qos
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.rosbag2.storage_mcap import Channel, McapWriter, write_channel, write_string
from rosbags.rosbag2.storage_sqlite3 import Sqlite3Writer

if sys.version_info >= (3, 14):
    from compression import zstd
else:  # pragma: no cover - the rosbags dependency brings the backport
    from backports import zstd

__all__ = ['BAG_VERSION', 'ROS_DISTRO', 'STORAGE_PRESETS', 'TYPE_HASH', 'Rosbag2Writer', 'StoragePreset',
           'qos_profiles_text', 'rosbag2_metadata', 'write_metadata_file']

#: rosbag2 Jazzy's metadata version (rosbags writes the same layout for version 9).
BAG_VERSION = 9
ROS_DISTRO = 'jazzy'
#: A type hash as rosbag2 stores it: RIHS01 and the 32 bytes of the SHA-256 in hex.
TYPE_HASH = re.compile(r'^RIHS01_[0-9a-f]{64}$')


@dataclass(frozen=True)
class StoragePreset:
    """How the MCAP storage writes chunks (module docstring: rosbag2's presets)."""

    name: str
    chunk_size: int
    zstd_level: int | None  # None: chunks stay uncompressed


_MCAP_CHUNK = 768 * 1024
STORAGE_PRESETS = {
    'none': StoragePreset('none', _MCAP_CHUNK, None),
    'fastwrite': StoragePreset('fastwrite', _MCAP_CHUNK, None),
    'zstd_fast': StoragePreset('zstd_fast', _MCAP_CHUNK, -5),
    'zstd_small': StoragePreset('zstd_small', 4 * 1024 * 1024, 19),
}

# ---- rosbag2's serialized forms ----------------------------------------------------------
_QOS_KEYS = ('history', 'depth', 'reliability', 'durability', 'deadline', 'lifespan', 'liveliness',
             'liveliness_lease_duration', 'avoid_ros_namespace_conventions')
_METADATA_KEYS = ('version', 'storage_identifier', 'duration', 'starting_time', 'message_count',
                  'topics_with_message_count', 'compression_format', 'compression_mode',
                  'relative_file_paths', 'files', 'custom_data', 'ros_distro')
_TOPIC_KEYS = ('name', 'type', 'serialization_format', 'offered_qos_profiles', 'type_description_hash')


def _qos_dict(spec: Qos) -> dict[str, Any]:
    # BagWriter gives normalised profiles (QosSpec.to_rosbags: 0 / legacy durations -> infinite).
    return {
        'history': spec.history.name.lower(),
        'depth': spec.depth,
        'reliability': spec.reliability.name.lower(),
        'durability': spec.durability.name.lower(),
        'deadline': {'sec': spec.deadline.sec, 'nsec': spec.deadline.nsec},
        'lifespan': {'sec': spec.lifespan.sec, 'nsec': spec.lifespan.nsec},
        'liveliness': spec.liveliness.name.lower(),
        'liveliness_lease_duration': {'sec': spec.liveliness_lease_duration.sec,
                                      'nsec': spec.liveliness_lease_duration.nsec},
        'avoid_ros_namespace_conventions': bool(spec.avoid_ros_namespace_conventions),
    }


def _dump(value: Any) -> str:
    return yaml.safe_dump(value, sort_keys=False, default_flow_style=False).rstrip('\n')


def qos_profiles_text(profiles: Sequence[Qos]) -> str:
    """The MCAP channel's ``offered_qos_profiles``: rosbag2's YAML list of profiles (v9 names)."""
    return _dump([_qos_dict(q) for q in profiles]) if profiles else '[]'


def _time(value: dict[str, int]) -> dict[str, int]:
    return {'sec': value['sec'], 'nsec': value['nsec']}


def _rosbag2_qos(q: dict[str, Any]) -> dict[str, Any]:
    out = {key: q[key] for key in _QOS_KEYS if key in q}
    for key in ('deadline', 'lifespan', 'liveliness_lease_duration'):
        if isinstance(out.get(key), dict):
            out[key] = _time(out[key])
    return out


def rosbag2_metadata(info: dict[str, Any], ros_distro: str) -> dict[str, Any]:
    """rosbags' metadata mapping with rosbag2 Jazzy's key order and ``ros_distro``."""
    topics = []
    for entry in info.get('topics_with_message_count') or []:
        meta = dict(entry['topic_metadata'])
        meta['offered_qos_profiles'] = [_rosbag2_qos(q) for q in meta.get('offered_qos_profiles') or []]
        topics.append({'topic_metadata': {key: meta.get(key, '') for key in _TOPIC_KEYS},
                       'message_count': entry['message_count']})
    out = {key: info.get(key) for key in _METADATA_KEYS}
    out['topics_with_message_count'] = topics
    out['files'] = [{key: f[key] for key in ('path', 'starting_time', 'duration', 'message_count')}
                    for f in info.get('files') or []]
    out['ros_distro'] = ros_distro
    return out


def write_metadata_file(bag: Path, metadata: dict[str, Any]) -> None:
    """metadata.yaml of the bag directory, replaced at once (a reader never sees half of it)."""
    text = _dump({'rosbag2_bagfile_information': metadata}) + '\n'
    tmp = bag / 'metadata.yaml.tmp'
    tmp.write_text(text, 'utf8')
    tmp.replace(bag / 'metadata.yaml')


class _Rosbag2Storage:
    """What both storages share: the serialized metadata as rosbag2 writes it."""

    ros_distro = ROS_DISTRO
    metadata: dict[str, Any] | None = None

    def _rosbag2_text(self, text: str) -> str:
        self.metadata = rosbag2_metadata(yaml.safe_load(text), self.ros_distro)
        return _dump(self.metadata)


class _McapStorage(_Rosbag2Storage, McapWriter):
    """rosbags' MCAP storage with rosbag2's channel metadata, presets and serialized metadata."""

    def __init__(self, path: Path, compression: Any) -> None:
        super().__init__(path, compression)
        self.preset = STORAGE_PRESETS['none']
        self._finishing = False

    def use_preset(self, preset: StoragePreset) -> None:
        self.preset = preset
        if preset.zstd_level is None:
            self.compression, self.compressor = '', (lambda data: data)
        else:
            self.compression = 'zstd'
            self.compressor = functools.partial(zstd.compress, level=preset.zstd_level)

    def add_connection(self, connection: Connection, offered_qos_profiles: str) -> None:
        # As rosbag2_storage_mcap's create_topic: the QoS list and the topic's type hash.
        metadata = BytesIO()
        write_string(metadata, 'offered_qos_profiles')
        write_string(metadata, qos_profiles_text(connection.ext.offered_qos_profiles))
        write_string(metadata, 'topic_type_hash')
        write_string(metadata, connection.digest)
        self.channels.append(Channel(connection.id, connection.msgtype, connection.topic,
                                     connection.ext.serialization_format, metadata.getvalue()))
        self.channel_stats[connection.id] = 0
        write_channel(self.chunk.bio, self.channels[-1], self.schemas)

    def write(self, connection: Connection, timestamp: int, data: bytes | memoryview) -> None:
        super().write(connection, timestamp, data)
        if self.chunk.bio.tell() >= self.preset.chunk_size:
            self.close_chunk_now()

    def close_chunk(self) -> None:
        # rosbags closes a chunk past 1 MiB; here the preset's chunk size decides.
        if self._finishing or self.chunk.bio.tell() >= self.preset.chunk_size:
            self.close_chunk_now()

    def close_chunk_now(self) -> None:
        super().close_chunk()
        # Into the OS at once: a killed recorder loses at most the chunk it was filling, not the
        # buffered tail (message indexes) of the last one it wrote.
        self.bio.flush()

    def close(self, version: int, metadata: str) -> None:
        self._finishing = True
        super().close(version, self._rosbag2_text(metadata))


class _Sqlite3Storage(_Rosbag2Storage, Sqlite3Writer):
    def close(self, version: int, metadata: str) -> None:
        super().close(version, self._rosbag2_text(metadata))


class Rosbag2Writer(Writer):
    STORAGE_PLUGINS = {StoragePlugin.SQLITE3: _Sqlite3Storage, StoragePlugin.MCAP: _McapStorage}

    def __init__(self, path: Path, storage_plugin: StoragePlugin, preset: StoragePreset, ros_distro: str):
        super().__init__(path, version=BAG_VERSION, storage_plugin=storage_plugin)
        self.preset = preset
        self.ros_distro = ros_distro

    def open(self) -> None:
        super().open()
        self.storage.ros_distro = self.ros_distro
        if isinstance(self.storage, _McapStorage):
            self.storage.use_preset(self.preset)

    def close(self) -> None:
        storage = self.storage
        super().close()
        # rosbags wrote its own metadata.yaml; rewrite it with what the storage got.
        write_metadata_file(self.path, storage.metadata)

    def close_pending_chunk(self) -> bool:
        """Write the chunk being filled now, whatever its size (False: no message in it, or sqlite3)."""
        if isinstance(self.storage, _McapStorage) and self.storage.chunk.msgs:
            self.storage.close_chunk_now()
            return True
        return False

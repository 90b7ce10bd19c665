"""Check a bag against the format rosbag2 Jazzy writes (metadata version 9, MCAP storage).

    problems = check_bag(path)          # [] when the bag is as rosbag2 Jazzy writes it
    python -m collab_tools.core.bag_check BAG [--ros-distro jazzy]   # exit 1 with the problems

What is checked, each problem naming the key or topic:

* metadata.yaml: ``rosbag2_bagfile_information`` with every key rosbag2 Jazzy writes,
  ``version: 9``, ``ros_distro`` (jazzy), message counts adding up, the listed files present;
* per topic: name, type, ``serialization_format: cdr``, ``type_description_hash`` =
  ``RIHS01_`` + 64 hex digits, ``offered_qos_profiles`` a list of profiles with rosbag2's
  nine keys, v9 policy names and ``{sec, nsec}`` durations;
* the MCAP file (storage ``mcap``): a ``ros2`` profile, per topic one channel whose metadata
  holds ``offered_qos_profiles`` (the same YAML list) and ``topic_type_hash`` equal to the
  metadata's ``type_description_hash``, a non-empty ``ros2msg``/``ros2idl`` schema, and a
  ``rosbag2`` metadata record whose ``serialized_metadata`` has the same ``ros_distro``.
"""
from __future__ import annotations

import argparse
import re
import struct
import sys
from pathlib import Path
from typing import Any

import yaml

__all__ = ['MCAP_MAGIC', 'METADATA_KEYS', 'check_bag', 'check_metadata', 'read_mcap_summary']

METADATA_KEYS = ('version', 'storage_identifier', 'duration', 'starting_time', 'message_count',
                 'topics_with_message_count', 'compression_format', 'compression_mode',
                 'relative_file_paths', 'files', 'custom_data', 'ros_distro')
TOPIC_KEYS = ('name', 'type', 'serialization_format', 'offered_qos_profiles', 'type_description_hash')
QOS_KEYS = ('history', 'depth', 'reliability', 'durability', 'deadline', 'lifespan', 'liveliness',
            'liveliness_lease_duration', 'avoid_ros_namespace_conventions')
# rmw's *_to_str names (what rosbag2 v9 writes), plus 'unknown'.
POLICIES = {
    'history': {'system_default', 'keep_last', 'keep_all', 'unknown'},
    'reliability': {'system_default', 'reliable', 'best_effort', 'best_available', 'unknown'},
    'durability': {'system_default', 'transient_local', 'volatile', 'best_available', 'unknown'},
    'liveliness': {'system_default', 'automatic', 'manual_by_topic', 'best_available', 'unknown'},
}
TYPE_HASH = re.compile(r'^RIHS01_[0-9a-f]{64}$')
BAG_VERSION = 9
MCAP_MAGIC = b'\x89MCAP0\r\n'


def _check_qos_list(profiles: Any, where: str) -> list[str]:
    if not isinstance(profiles, list):
        return [f'{where}: offered_qos_profiles must be a list of profiles (got {type(profiles).__name__})']
    problems = []
    for index, qos in enumerate(profiles):
        at = f'{where}: offered_qos_profiles[{index}]'
        if not isinstance(qos, dict):
            problems.append(f'{at}: not a mapping')
            continue
        missing = [key for key in QOS_KEYS if key not in qos]
        if missing:
            problems.append(f'{at}: missing {", ".join(missing)}')
        for key, names in POLICIES.items():
            if key in qos and qos[key] not in names:
                problems.append(f'{at}.{key}: {qos[key]!r} is not one of {", ".join(sorted(names))}')
        if 'depth' in qos and (not isinstance(qos['depth'], int) or qos['depth'] < 0):
            problems.append(f'{at}.depth: must be an int >= 0 (got {qos["depth"]!r})')
        for key in ('deadline', 'lifespan', 'liveliness_lease_duration'):
            value = qos.get(key)
            if key in qos and not (isinstance(value, dict) and set(value) == {'sec', 'nsec'}
                                   and all(isinstance(v, int) and v >= 0 for v in value.values())):
                problems.append(f'{at}.{key}: must be {{sec, nsec}} non-negative ints (got {value!r})')
        if 'avoid_ros_namespace_conventions' in qos and not isinstance(qos['avoid_ros_namespace_conventions'], bool):
            problems.append(f'{at}.avoid_ros_namespace_conventions: must be a bool')
    return problems


def check_metadata(info: Any, ros_distro: str = 'jazzy') -> list[str]:
    """Problems of a ``rosbag2_bagfile_information`` mapping (see the module docstring)."""
    if not isinstance(info, dict):
        return ['metadata.yaml: rosbag2_bagfile_information must be a mapping']
    problems = [f'metadata.yaml: missing key {key}' for key in METADATA_KEYS if key not in info]
    if info.get('version') != BAG_VERSION:
        problems.append(f'metadata.yaml: version is {info.get("version")!r}, rosbag2 Jazzy writes {BAG_VERSION}')
    if info.get('ros_distro') != ros_distro:
        problems.append(f'metadata.yaml: ros_distro is {info.get("ros_distro")!r}, expected {ros_distro!r}')
    topics = info.get('topics_with_message_count')
    if not isinstance(topics, list):
        return problems + ['metadata.yaml: topics_with_message_count must be a list']
    total = 0
    for index, entry in enumerate(topics):
        meta = entry.get('topic_metadata') if isinstance(entry, dict) else None
        if not isinstance(meta, dict):
            problems.append(f'metadata.yaml: topics_with_message_count[{index}]: no topic_metadata mapping')
            continue
        where = f'topic {meta.get("name", index)}'
        problems += [f'{where}: missing {key}' for key in TOPIC_KEYS if key not in meta]
        if meta.get('serialization_format', 'cdr') != 'cdr':
            problems.append(f'{where}: serialization_format is {meta["serialization_format"]!r}, not cdr')
        digest = meta.get('type_description_hash')
        if 'type_description_hash' in meta and not (isinstance(digest, str) and TYPE_HASH.match(digest)):
            problems.append(f'{where}: type_description_hash {digest!r} is not RIHS01_ and 64 hex digits')
        if 'offered_qos_profiles' in meta:
            problems += _check_qos_list(meta['offered_qos_profiles'], where)
        count = entry.get('message_count')
        if not isinstance(count, int) or count < 0:
            problems.append(f'{where}: message_count must be an int >= 0 (got {count!r})')
        else:
            total += count
    if isinstance(info.get('message_count'), int) and info['message_count'] != total:
        problems.append(f'metadata.yaml: message_count {info["message_count"]} differs from the topics\' sum {total}')
    return problems


# ---- MCAP ------------------------------------------------------------------------------------
def _string(data: bytes, offset: int) -> tuple[str, int]:
    (length,) = struct.unpack_from('<I', data, offset)
    start = offset + 4
    return data[start:start + length].decode(), start + length


def _string_map(data: bytes, offset: int) -> tuple[dict[str, str], int]:
    (length,) = struct.unpack_from('<I', data, offset)
    end, offset, out = offset + 4 + length, offset + 4, {}
    while offset < end:
        key, offset = _string(data, offset)
        out[key], offset = _string(data, offset)
    return out, end


def read_mcap_summary(path: Path) -> dict[str, Any]:
    """Profile, schemas, channels, metadata records and chunk compressions of an MCAP file.

    Only top-level records are read: the chunks' contents are not decompressed.

    Writers repeat schemas and channels in the summary section, outside the (maybe
    compressed) chunks, which is where this finds them. Raises ValueError for a file
    that is not MCAP.
    """
    data = Path(path).read_bytes()
    if not data.startswith(MCAP_MAGIC):
        raise ValueError(f'{path}: not an MCAP file (no magic bytes)')
    out: dict[str, Any] = {'profile': None, 'schemas': {}, 'channels': {}, 'metadata': {},
                           'chunk_compression': set()}
    offset = len(MCAP_MAGIC)
    while offset + 9 <= len(data):
        opcode, length = struct.unpack_from('<BQ', data, offset)
        body = data[offset + 9:offset + 9 + length]
        offset += 9 + length
        if opcode == 0x01:  # header
            out['profile'], _ = _string(body, 0)
        elif opcode == 0x03:  # schema
            (schema_id,) = struct.unpack_from('<H', body, 0)
            name, at = _string(body, 2)
            encoding, at = _string(body, at)
            (size,) = struct.unpack_from('<I', body, at)
            out['schemas'][schema_id] = {'name': name, 'encoding': encoding, 'data': body[at + 4:at + 4 + size]}
        elif opcode == 0x04:  # channel
            channel_id, schema_id = struct.unpack_from('<HH', body, 0)
            topic, at = _string(body, 4)
            encoding, at = _string(body, at)
            metadata, _ = _string_map(body, at)
            out['channels'][channel_id] = {'topic': topic, 'schema_id': schema_id, 'message_encoding': encoding,
                                           'metadata': metadata}
        elif opcode == 0x06:  # chunk: start, end, uncompressed size (u64), crc (u32), compression
            out['chunk_compression'].add(_string(body, 28)[0])
        elif opcode == 0x0C:  # metadata
            name, at = _string(body, 0)
            out['metadata'][name], _ = _string_map(body, at)
        elif opcode == 0x02:  # footer
            break
    return out


def _check_mcap(path: Path, info: dict[str, Any], ros_distro: str) -> list[str]:
    try:
        summary = read_mcap_summary(path)
    except (OSError, ValueError, struct.error, UnicodeDecodeError) as error:
        return [f'{path.name}: cannot read the MCAP summary ({error})']
    problems = []
    if summary['profile'] != 'ros2':
        problems.append(f'{path.name}: MCAP profile is {summary["profile"]!r}, not ros2')
    channels = {c['topic']: c for c in summary['channels'].values()}
    for entry in info.get('topics_with_message_count') or []:
        meta = entry.get('topic_metadata') or {}
        topic = meta.get('name')
        channel = channels.get(topic)
        if channel is None:
            problems.append(f'topic {topic}: no channel in {path.name}')
            continue
        metadata = channel['metadata']
        if metadata.get('topic_type_hash') != meta.get('type_description_hash'):
            problems.append(f'topic {topic}: channel topic_type_hash {metadata.get("topic_type_hash")!r} differs '
                            f'from metadata.yaml\'s {meta.get("type_description_hash")!r}')
        try:
            problems += _check_qos_list(yaml.safe_load(metadata.get('offered_qos_profiles', '')),
                                        f'topic {topic} (channel)')
        except yaml.YAMLError as error:
            problems.append(f'topic {topic}: channel offered_qos_profiles is not YAML ({error})')
        schema = summary['schemas'].get(channel['schema_id'])
        if schema is None or schema['name'] != meta.get('type'):
            problems.append(f'topic {topic}: no schema named {meta.get("type")!r} for its channel')
        elif schema['encoding'] not in ('ros2msg', 'ros2idl') or not schema['data'].strip():
            problems.append(f'topic {topic}: schema {schema["name"]} is empty or not ros2msg/ros2idl '
                            f'(encoding {schema["encoding"]!r})')
    record = summary['metadata'].get('rosbag2')
    if record is None or 'serialized_metadata' not in record:
        problems.append(f'{path.name}: no rosbag2 metadata record with serialized_metadata')
    else:
        serialized = yaml.safe_load(record['serialized_metadata']) or {}
        if serialized.get('ros_distro') != ros_distro:
            problems.append(f'{path.name}: serialized_metadata ros_distro is {serialized.get("ros_distro")!r}, '
                            f'expected {ros_distro!r}')
    return problems


def check_bag(path: str | Path, ros_distro: str = 'jazzy') -> list[str]:
    """Problems that make the bag at ``path`` differ from what rosbag2 Jazzy writes ([] = none)."""
    path = Path(path)
    try:
        data = yaml.safe_load((path / 'metadata.yaml').read_text())
    except OSError as error:
        return [f'{path}: cannot read metadata.yaml ({error.strerror})']
    except yaml.YAMLError as error:
        return [f'{path}/metadata.yaml: invalid YAML ({error})']
    info = data.get('rosbag2_bagfile_information') if isinstance(data, dict) else None
    problems = check_metadata(info, ros_distro)
    if not isinstance(info, dict):
        return problems
    files = info.get('relative_file_paths') or []
    for name in files:
        if not (path / name).is_file():
            problems.append(f'metadata.yaml: relative_file_paths lists {name}, which does not exist')
    if info.get('storage_identifier') == 'mcap':
        for name in files:
            if (path / name).is_file():
                problems += _check_mcap(path / name, info, ros_distro)
    return problems


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description='Check a bag against the format rosbag2 Jazzy writes.')
    parser.add_argument('bag', type=Path)
    parser.add_argument('--ros-distro', default='jazzy')
    args = parser.parse_args(argv)
    problems = check_bag(args.bag, args.ros_distro)
    for problem in problems:
        print(problem)
    print(f'{args.bag}: {"OK" if not problems else f"{len(problems)} problem(s)"}')
    return 1 if problems else 0


if __name__ == '__main__':
    sys.exit(main())

"""Bags as rosbag2 Jazzy writes them: distro, per-channel type hash, QoS layout, presets, actions."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from collab_tools.core.bag_check import check_bag, read_mcap_summary
from collab_tools.core.bag_types import (
    UnknownMessageTypeError,
    action_definitions,
    build_typestore,
    message_definition,
    normalize_type_name,
)
from collab_tools.core.bag_writer import STORAGE_PRESETS, BagWriter, QosSpec, qos_profiles_text

WS = Path(__file__).resolve().parents[3]
ACTION_FILE = WS / 'interfaces' / 'bridge_interfaces' / 'action' / 'PickAndPlace.action'
FEEDBACK = 'bridge_interfaces/action/PickAndPlace_FeedbackMessage'
STATUS = 'action_msgs/msg/GoalStatusArray'
STRING_RIHS01 = 'RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18'
QOS = [QosSpec('keep_last', 10, 'reliable', 'volatile')]


@pytest.fixture
def action_prefix(bridge_prefix: Path) -> Path:
    """The fake prefix of conftest plus the workspace's PickAndPlace.action."""
    action_dir = bridge_prefix / 'share' / 'bridge_interfaces' / 'action'
    action_dir.mkdir(parents=True)
    shutil.copy(ACTION_FILE, action_dir / ACTION_FILE.name)
    return bridge_prefix


def _feedback(store, phase: str, progress: float):
    T = store.types
    uuid = T['unique_identifier_msgs/msg/UUID'](uuid=__import__('numpy').arange(16, dtype='uint8'))
    feedback = T['bridge_interfaces/action/PickAndPlace_Feedback'](phase=phase, progress=progress)
    return T[FEEDBACK](goal_id=uuid, feedback=feedback)


def _string(store, text: str) -> bytes:
    return bytes(store.serialize_cdr(store.types['std_msgs/msg/String'](data=text), 'std_msgs/msg/String'))


def _action_bag(path: Path, store, preset: str = 'none', n: int = 5) -> Path:
    with BagWriter(path, store, storage_preset=preset) as writer:
        writer.add_topic('/leader_arm/pick_and_place/_action/feedback', FEEDBACK, QOS)
        writer.add_topic('/leader_arm/pick_and_place/_action/status', STATUS,
                         [QosSpec('keep_last', 1, 'reliable', 'transient_local')])
        for i in range(n):
            raw = bytes(store.serialize_cdr(_feedback(store, f'phase{i}', i / n), FEEDBACK))
            writer.write('/leader_arm/pick_and_place/_action/feedback', 100 + i, raw)
        status = store.types[STATUS](status_list=[])
        writer.write('/leader_arm/pick_and_place/_action/status', 200, bytes(store.serialize_cdr(status, STATUS)))
    return path


# ------------------------------------------------------------------ action types
def test_action_file_gives_the_generated_messages():
    defs = action_definitions('bridge_interfaces', 'PickAndPlace', ACTION_FILE.read_text())
    assert set(defs) == {f'bridge_interfaces/action/PickAndPlace_{p}'
                         for p in ('Goal', 'Result', 'Feedback', 'FeedbackMessage')}
    assert 'string object_name' in defs['bridge_interfaces/action/PickAndPlace_Goal']
    assert 'uint8 PLACED = 0' in defs['bridge_interfaces/action/PickAndPlace_Result']
    assert defs[FEEDBACK].split('\n')[:2] == ['unique_identifier_msgs/UUID goal_id',
                                               'bridge_interfaces/action/PickAndPlace_Feedback feedback']
    with pytest.raises(ValueError, match='PickAndPlace.action'):
        action_definitions('bridge_interfaces', 'PickAndPlace', 'string a\n---\nstring b\n')


def test_action_type_names_normalise():
    assert normalize_type_name(FEEDBACK) == FEEDBACK
    assert normalize_type_name('pkg/action/Do_Goal') == 'pkg/action/Do_Goal'
    for bad in ('pkg/action/Do', 'pkg/action/Do_Request', 'pkg/action/_Goal'):
        with pytest.raises(ValueError, match='action'):
            normalize_type_name(bad)


def test_action_types_resolve_and_hash_like_rosidl(action_prefix):
    store = build_typestore([FEEDBACK, STATUS, 'bridge_interfaces/action/PickAndPlace_Result',
                             'bridge_interfaces/action/PickAndPlace_Goal'], prefixes=[action_prefix])
    # A relative type in the .action file is a message of the package (Point is geometry_msgs' here,
    # spelled in full; the Result's placed_position must not become an action type).
    result = dict(store.fielddefs['bridge_interfaces/action/PickAndPlace_Result'][1])
    assert result['placed_position'][1] == 'geometry_msgs/msg/Point'
    msg = _feedback(store, 'lift', 0.25)
    back = store.deserialize_cdr(store.serialize_cdr(msg, FEEDBACK), FEEDBACK)
    assert (back.feedback.phase, back.feedback.progress) == ('lift', 0.25)
    assert list(back.goal_id.uuid) == list(range(16))
    found = 0
    for prefix in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep):
        described = Path(prefix) / 'share' / 'bridge_interfaces' / 'action' / 'PickAndPlace.json'
        if described.is_file():
            hashes = {h['type_name']: h['hash_string'] for h in json.loads(described.read_text())['type_hashes']}
            for name in (FEEDBACK, 'bridge_interfaces/action/PickAndPlace_Goal',
                         'bridge_interfaces/action/PickAndPlace_Result'):
                assert store.hash_rihs01(name) == hashes[name]
                found += 1
    assert found, 'bridge_interfaces is not built/installed on AMENT_PREFIX_PATH (scripts/setup builds it)'


def test_action_message_definition_is_rosbag2_style(action_prefix):
    store = build_typestore([FEEDBACK], prefixes=[action_prefix])
    text = message_definition(store, FEEDBACK)
    sections = text.split('=' * 80 + '\n')
    assert sections[0] == 'unique_identifier_msgs/UUID goal_id\nbridge_interfaces/action/PickAndPlace_Feedback feedback\n'
    assert sections[1] == 'MSG: unique_identifier_msgs/UUID\nuint8[16] uuid\n'
    assert sections[2] == 'MSG: bridge_interfaces/action/PickAndPlace_Feedback\nstring phase\nfloat32 progress\n'
    # Plain messages: exactly rosbags' (and rosbag2's) text.
    assert message_definition(store, STATUS) == store.generate_msgdef(STATUS, ros_version=2)[0]


def test_unknown_action_names_the_searched_prefixes(bridge_prefix):
    with pytest.raises(UnknownMessageTypeError, match='PickAndPlace_FeedbackMessage') as info:
        build_typestore([FEEDBACK], prefixes=[bridge_prefix])  # no .action file there
    assert 'share/<pkg>/action/<Name>.action' in str(info.value) and str(bridge_prefix / 'share') in str(info.value)


def test_action_bag_decodes_from_its_own_definitions(tmp_path, action_prefix):
    """A fresh process without ROS reads the feedback back from the bag's schema alone."""
    bag = _action_bag(tmp_path / 'bag', build_typestore([FEEDBACK, STATUS], prefixes=[action_prefix]))
    assert check_bag(bag) == []
    code = ('import sys\n'
            'from collab_tools.core.bag_analysis import read_messages\n'
            'for topic, ts, m in read_messages(sys.argv[1]):\n'
            '    print(topic, ts, getattr(getattr(m, "feedback", None), "phase", len(getattr(m, "status_list", []))))\n')
    env = {k: v for k, v in os.environ.items()
           if not k.startswith(('AMENT_', 'ROS_', 'COLCON', 'CMAKE_PREFIX', 'PYTHONPATH'))}
    env['PYTHONPATH'] = str(WS / 'src' / 'collab_tools')
    res = subprocess.run([sys.executable, '-c', code, str(bag)], env=env, capture_output=True, text=True,
                         timeout=120, check=False)
    assert res.returncode == 0, res.stderr
    lines = res.stdout.split('\n')
    assert lines[:5] == [f'/leader_arm/pick_and_place/_action/feedback {100 + i} phase{i}' for i in range(5)]
    assert lines[5] == '/leader_arm/pick_and_place/_action/status 200 0'


# ------------------------------------------------------------------ metadata as rosbag2 Jazzy writes it
def test_metadata_has_rosbag2_keys_in_order_distro_and_hashes(tmp_path, action_prefix):
    store = build_typestore([FEEDBACK, STATUS, 'std_msgs/msg/String'], prefixes=[action_prefix])
    bag = _action_bag(tmp_path / 'bag', store)
    info = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert list(info) == ['version', 'storage_identifier', 'duration', 'starting_time', 'message_count',
                          'topics_with_message_count', 'compression_format', 'compression_mode',
                          'relative_file_paths', 'files', 'custom_data', 'ros_distro']
    assert (info['version'], info['ros_distro']) == (9, 'jazzy')
    topic = info['topics_with_message_count'][0]
    assert list(topic) == ['topic_metadata', 'message_count']
    assert list(topic['topic_metadata']) == ['name', 'type', 'serialization_format', 'offered_qos_profiles',
                                             'type_description_hash']
    qos = topic['topic_metadata']['offered_qos_profiles'][0]
    assert list(qos) == ['history', 'depth', 'reliability', 'durability', 'deadline', 'lifespan', 'liveliness',
                         'liveliness_lease_duration', 'avoid_ros_namespace_conventions']
    assert list(qos['deadline']) == ['sec', 'nsec']

    summary = read_mcap_summary(bag / info['relative_file_paths'][0])
    hashes = {t['topic_metadata']['name']: t['topic_metadata']['type_description_hash']
              for t in info['topics_with_message_count']}
    channels = {c['topic']: c['metadata'] for c in summary['channels'].values()}
    assert set(channels) == set(hashes)
    for name, digest in hashes.items():
        assert channels[name]['topic_type_hash'] == digest == store.hash_rihs01(
            next(t['topic_metadata']['type'] for t in info['topics_with_message_count']
                 if t['topic_metadata']['name'] == name))
        # The channel's QoS text is rosbag2's YAML list, the same profiles as metadata.yaml.
        assert yaml.safe_load(channels[name]['offered_qos_profiles']) == next(
            t['topic_metadata']['offered_qos_profiles'] for t in info['topics_with_message_count']
            if t['topic_metadata']['name'] == name)
    serialized = yaml.safe_load(summary['metadata']['rosbag2']['serialized_metadata'])
    assert serialized['ros_distro'] == 'jazzy' and serialized['version'] == 9


def test_qos_profiles_text_is_rosbag2s_yaml_list():
    text = qos_profiles_text([QosSpec('keep_last', 5, 'best_effort', 'volatile', deadline_ns=1_500_000_000)
                              .to_rosbags()])
    assert text.startswith('- history: keep_last\n  depth: 5\n  reliability: best_effort\n  durability: volatile\n'
                           '  deadline:\n    sec: 1\n    nsec: 500000000\n')
    assert qos_profiles_text([]) == '[]'


def test_publishers_type_hash_is_checked(tmp_path):
    store = build_typestore(['std_msgs/msg/String'], prefixes=[])
    with BagWriter(tmp_path / 'bag', store) as writer:
        writer.add_topic('/ok', 'std_msgs/msg/String', QOS, type_hash=STRING_RIHS01)
        with pytest.raises(ValueError, match='/other.*differs'):
            writer.add_topic('/other', 'std_msgs/msg/String', QOS, type_hash='RIHS01_' + '0' * 64)
        with pytest.raises(ValueError, match='RIHS01_ and 64 hex'):
            writer.add_topic('/bad', 'std_msgs/msg/String', QOS, type_hash='md5:abc')
        writer.set_custom_data('unrecorded_topics', '/other: hash differs')
    info = yaml.safe_load((tmp_path / 'bag' / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert [t['topic_metadata']['name'] for t in info['topics_with_message_count']] == ['/ok']
    assert info['custom_data'] == {'unrecorded_topics': '/other: hash differs'}


def test_ros_distro_and_preset_arguments_are_checked(tmp_path):
    store = build_typestore(['std_msgs/msg/String'], prefixes=[])
    with pytest.raises(ValueError, match='storage_preset'):
        BagWriter(tmp_path / 'a', store, storage_preset='zstd')
    with pytest.raises(ValueError, match='MCAP preset'):
        BagWriter(tmp_path / 'b', store, storage='sqlite3', storage_preset='zstd_fast')
    with pytest.raises(ValueError, match='ros_distro'):
        BagWriter(tmp_path / 'c', store, ros_distro='')
    with BagWriter(tmp_path / 'd', store, ros_distro='rolling') as writer:
        writer.add_topic('/a', 'std_msgs/msg/String', QOS)
    assert check_bag(tmp_path / 'd', ros_distro='rolling') == []
    assert any("ros_distro is 'rolling'" in p for p in check_bag(tmp_path / 'd'))


# ------------------------------------------------------------------ presets
@pytest.mark.parametrize('preset', sorted(STORAGE_PRESETS))
def test_storage_presets_compress_chunks_like_rosbag2(tmp_path, preset):
    store = build_typestore(['std_msgs/msg/String'], prefixes=[])
    bag = tmp_path / 'bag'
    with BagWriter(bag, store, storage_preset=preset) as writer:
        writer.add_topic('/a', 'std_msgs/msg/String', QOS)
        for i in range(20000):
            writer.write('/a', i, _string(store, f'{i:06d} ' + 'x' * 90))
    summary = read_mcap_summary(bag / 'bag.mcap')
    expected = '' if STORAGE_PRESETS[preset].zstd_level is None else 'zstd'
    assert summary['chunk_compression'] == {expected}
    size = (bag / 'bag.mcap').stat().st_size
    text_size = 20000 * 97
    assert size > text_size if not expected else size < 0.4 * text_size
    assert check_bag(bag) == []
    from collab_tools.core.bag_analysis import read_messages
    texts = [m.data for _, _, m in read_messages(bag)]
    assert len(texts) == 20000 and texts[12345] == '012345 ' + 'x' * 90


# ------------------------------------------------------------------ the checker itself
def test_check_bag_names_what_rosbags_alone_gets_wrong(tmp_path):
    """A bag from plain rosbags: distro 'rosbags', no topic_type_hash per channel."""
    from rosbags.rosbag2 import StoragePlugin, Writer

    store = build_typestore(['std_msgs/msg/String'], prefixes=[])
    with Writer(tmp_path / 'bag', version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        connection = writer.add_connection('/a', 'std_msgs/msg/String', typestore=store)
        writer.write(connection, 1, _string(store, 'x'))
    problems = check_bag(tmp_path / 'bag')
    assert "metadata.yaml: ros_distro is 'rosbags', expected 'jazzy'" in problems
    assert any(p.startswith('topic /a: channel topic_type_hash None differs') for p in problems)
    assert any('serialized_metadata ros_distro' in p for p in problems)


def test_check_bag_names_bad_metadata(tmp_path, action_prefix):
    bag = _action_bag(tmp_path / 'bag', build_typestore([FEEDBACK, STATUS], prefixes=[action_prefix]))
    path = bag / 'metadata.yaml'
    data = yaml.safe_load(path.read_text())
    info = data['rosbag2_bagfile_information']
    info['version'] = 8
    del info['custom_data']
    info['message_count'] += 1
    first = info['topics_with_message_count'][0]['topic_metadata']
    first['type_description_hash'] = 'RIHS01_xyz'
    first['offered_qos_profiles'][0]['reliability'] = 1
    del first['offered_qos_profiles'][0]['lifespan']
    info['topics_with_message_count'][1]['topic_metadata']['offered_qos_profiles'] = 'not a list'
    path.write_text(yaml.safe_dump(data))
    problems = check_bag(bag)
    name = first['name']
    for expected in ('metadata.yaml: version is 8, rosbag2 Jazzy writes 9',
                     'metadata.yaml: missing key custom_data',
                     "metadata.yaml: message_count 7 differs from the topics' sum 6",
                     f"topic {name}: type_description_hash 'RIHS01_xyz' is not RIHS01_ and 64 hex digits",
                     f'topic {name}: offered_qos_profiles[0]: missing lifespan',
                     'topic /leader_arm/pick_and_place/_action/status: offered_qos_profiles must be a list'):
        assert any(p.startswith(expected) for p in problems), (expected, problems)
    assert any(p.startswith(f'topic {name}: offered_qos_profiles[0].reliability: 1 is not one of') for p in problems)
    assert any(p.startswith(f'topic {name}: channel topic_type_hash') for p in problems)
    assert check_bag(tmp_path / 'missing')[0].startswith(f'{tmp_path / "missing"}: cannot read metadata.yaml')

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from collab_tools.core.bag_types import (
    UnknownMessageTypeError,
    build_typestore,
    find_message_definitions,
    normalize_type_name,
)


def _fake_prefix(root: Path) -> Path:
    msg = root / 'share' / 'fake_pkg' / 'msg'
    msg.mkdir(parents=True)
    (msg / 'Foo.msg').write_text(
        '# a fake message\n'
        'uint8 MODE_A=1\n'
        'geometry_msgs/Pose pose   # nests a standard type\n'
        'Bar[] bars                # nests a fake type of the same package\n'
        'fake_pkg/Bar single\n'
        'string<=8 tag\n'
    )
    (msg / 'Bar.msg').write_text('float64 value\nint32[3] triple\n')
    return root


def test_find_message_definitions_reads_share_msg(tmp_path):
    prefix = _fake_prefix(tmp_path / 'p')
    defs = find_message_definitions([prefix])
    assert set(defs) == {'fake_pkg/msg/Foo', 'fake_pkg/msg/Bar'}
    assert 'float64 value' in defs['fake_pkg/msg/Bar']


def test_find_message_definitions_defaults_to_ament_prefix_path(tmp_path, monkeypatch):
    prefix = _fake_prefix(tmp_path / 'p')
    monkeypatch.setenv('AMENT_PREFIX_PATH', f'{tmp_path / "missing"}{os.pathsep}{prefix}')
    assert 'fake_pkg/msg/Foo' in find_message_definitions()
    monkeypatch.setenv('AMENT_PREFIX_PATH', '')
    assert find_message_definitions() == {}
    monkeypatch.delenv('AMENT_PREFIX_PATH')
    assert find_message_definitions() == {}


def test_first_prefix_wins(tmp_path):
    a = _fake_prefix(tmp_path / 'a')
    b = tmp_path / 'b'
    (b / 'share' / 'fake_pkg' / 'msg').mkdir(parents=True)
    (b / 'share' / 'fake_pkg' / 'msg' / 'Bar.msg').write_text('int8 other\n')
    assert 'float64 value' in find_message_definitions([a, b])['fake_pkg/msg/Bar']
    assert 'int8 other' in find_message_definitions([b, a])['fake_pkg/msg/Bar']


def test_build_typestore_custom_nested_type_round_trips(tmp_path):
    prefix = _fake_prefix(tmp_path / 'p')
    store = build_typestore(['fake_pkg/Foo'], prefixes=[prefix])  # 'pkg/Name' spelling
    assert 'fake_pkg/msg/Foo' in store.fielddefs
    assert 'fake_pkg/msg/Bar' in store.fielddefs  # nested dependency registered
    T = store.types
    Foo, Bar = T['fake_pkg/msg/Foo'], T['fake_pkg/msg/Bar']
    Pose, Point, Quat = T['geometry_msgs/msg/Pose'], T['geometry_msgs/msg/Point'], T['geometry_msgs/msg/Quaternion']
    import numpy as np

    msg = Foo(
        pose=Pose(position=Point(x=1.0, y=2.0, z=3.0), orientation=Quat(x=0.0, y=0.0, z=0.0, w=1.0)),
        bars=[Bar(value=1.5, triple=np.array([1, 2, 3], dtype=np.int32)),
              Bar(value=-2.0, triple=np.array([4, 5, 6], dtype=np.int32))],
        single=Bar(value=9.0, triple=np.array([7, 8, 9], dtype=np.int32)),
        tag='abc',
    )
    back = store.deserialize_cdr(store.serialize_cdr(msg, 'fake_pkg/msg/Foo'), 'fake_pkg/msg/Foo')
    assert back.pose.position.y == 2.0
    assert [b.value for b in back.bars] == [1.5, -2.0]
    assert list(back.bars[1].triple) == [4, 5, 6]
    assert back.single.value == 9.0 and back.tag == 'abc'
    assert Foo.MODE_A == 1
    msgdef, _ = store.generate_msgdef('fake_pkg/msg/Foo', ros_version=2)
    assert 'MSG: fake_pkg/Bar' in msgdef and 'MSG: geometry_msgs/Pose' in msgdef
    assert store.hash_rihs01('fake_pkg/msg/Foo').startswith('RIHS01_')


def test_build_typestore_standard_types_need_no_prefix():
    store = build_typestore(['std_msgs/msg/String', 'geometry_msgs/Twist'], prefixes=[])
    assert 'geometry_msgs/msg/Twist' in store.fielddefs


def test_unknown_type_names_type_and_prefixes(tmp_path):
    prefix = _fake_prefix(tmp_path / 'p')
    with pytest.raises(UnknownMessageTypeError) as info:
        build_typestore(['std_msgs/msg/String', 'nope_pkg/msg/Missing'], prefixes=[prefix])
    assert isinstance(info.value, ValueError)
    assert 'nope_pkg/msg/Missing' in str(info.value)
    assert str(prefix / 'share') in str(info.value)


def test_unknown_nested_type_names_the_dependency(tmp_path):
    msg = tmp_path / 'p' / 'share' / 'fake_pkg' / 'msg'
    msg.mkdir(parents=True)
    (msg / 'Outer.msg').write_text('other_pkg/Gone inner\n')
    with pytest.raises(UnknownMessageTypeError) as info:
        build_typestore(['fake_pkg/msg/Outer'], prefixes=[tmp_path / 'p'])
    assert 'other_pkg/msg/Gone' in str(info.value)
    assert 'fake_pkg/msg/Outer' in str(info.value)  # who needed it


def test_normalize_type_name():
    assert normalize_type_name('a/B') == 'a/msg/B'
    assert normalize_type_name('a/msg/B') == 'a/msg/B'
    for bad in ('B', 'a/srv/B', 'a//B', ''):
        with pytest.raises(ValueError):
            normalize_type_name(bad)


def test_workspace_bridge_types_hash_like_rosidl(bridge_prefix):
    """RIHS01 of the custom types equals what rosidl generates (when the workspace is built)."""
    store = build_typestore(['bridge_interfaces/msg/BodyStates', 'bridge_interfaces/msg/LabelLegend',
                             'bridge_interfaces/msg/SimulationStatus'], prefixes=[bridge_prefix])
    found = 0
    for prefix in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep):
        for name in ('BodyStates', 'BodyState', 'LabelLegend', 'BodyLabel', 'SimulationStatus'):
            desc = Path(prefix) / 'share' / 'bridge_interfaces' / 'msg' / f'{name}.json'
            if desc.is_file():
                want = json.loads(desc.read_text())['type_hashes'][0]
                assert store.hash_rihs01(want['type_name']) == want['hash_string']
                found += 1
    assert found, 'bridge_interfaces is not built/installed on AMENT_PREFIX_PATH (scripts/setup builds it)'

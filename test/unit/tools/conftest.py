"""Make ``collab_tools`` importable from the source tree for the unit tests."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

WS = Path(__file__).resolve().parents[3]
SRC = WS / 'src' / 'collab_tools'


def _ensure_source_package() -> None:
    try:
        import collab_tools  # noqa: F401
    except ImportError:
        sys.path.insert(0, str(SRC))
        return
    here = Path(collab_tools.__file__).resolve().parent
    if here != (SRC / 'collab_tools').resolve():
        # A stale installed copy: test the source instead.
        for name in [m for m in sys.modules if m == 'collab_tools' or m.startswith('collab_tools.')]:
            del sys.modules[name]
        sys.path.insert(0, str(SRC))


_ensure_source_package()

BRIDGE_MSG_DIR = WS / 'interfaces' / 'bridge_interfaces' / 'msg'


@pytest.fixture
def bridge_prefix(tmp_path: Path) -> Path:
    """A fake ament prefix with the workspace's bridge_interfaces .msg files (no build needed)."""
    prefix = tmp_path / 'fake_prefix'
    msg_dir = prefix / 'share' / 'bridge_interfaces' / 'msg'
    msg_dir.mkdir(parents=True)
    for src in BRIDGE_MSG_DIR.glob('*.msg'):
        (msg_dir / src.name).write_text(src.read_text())
    return prefix


def body_states_msg(typestore, stamp_ns: int, bodies: list[tuple[str, str, int, float, float, float]]):
    """A BodyStates message; bodies are (name, kind, label, x, y, vx)."""
    T = typestore.types
    Time = T['builtin_interfaces/msg/Time']
    Header = T['std_msgs/msg/Header']
    Pose = T['geometry_msgs/msg/Pose']
    Point = T['geometry_msgs/msg/Point']
    Quat = T['geometry_msgs/msg/Quaternion']
    Twist = T['geometry_msgs/msg/Twist']
    Vec = T['geometry_msgs/msg/Vector3']
    BodyState = T['bridge_interfaces/msg/BodyState']
    BodyStates = T['bridge_interfaces/msg/BodyStates']
    return BodyStates(
        header=Header(stamp=Time(sec=stamp_ns // 10**9, nanosec=stamp_ns % 10**9), frame_id='world'),
        bodies=[
            BodyState(
                name=name,
                kind=kind,
                label=label,
                pose=Pose(position=Point(x=x, y=y, z=0.0), orientation=Quat(x=0.0, y=0.0, z=0.0, w=1.0)),
                twist=Twist(linear=Vec(x=vx, y=0.0, z=0.0), angular=Vec(x=0.0, y=0.0, z=0.25)),
            )
            for name, kind, label, x, y, vx in bodies
        ],
    )


def twist_msg(typestore, vx: float, wz: float):
    T = typestore.types
    Vec = T['geometry_msgs/msg/Vector3']
    return T['geometry_msgs/msg/Twist'](linear=Vec(x=vx, y=0.0, z=0.0), angular=Vec(x=0.0, y=0.0, z=wz))


@pytest.fixture
def make_bag(bridge_prefix: Path):
    """make_bag(path, n=..., t0_ns=..., period_ns=...) -> path: a synthetic run bag.

    Topics: /chatter (String, transient_local), /robot_1/cmd_vel (Twist) and
    /sim/body_states (BodyStates with two mobile robots and one box), n messages each.
    """
    from collab_tools.core.bag_types import build_typestore
    from collab_tools.core.bag_writer import BagWriter, QosSpec

    typestore = build_typestore(
        ['std_msgs/msg/String', 'geometry_msgs/msg/Twist', 'bridge_interfaces/msg/BodyStates'],
        prefixes=[bridge_prefix],
    )

    def make(path: Path, n: int = 11, t0_ns: int = 1_700_000_000_000_000_000, period_ns: int = 100_000_000,
             topics: tuple[str, ...] = ('/chatter', '/robot_1/cmd_vel', '/sim/body_states')) -> Path:
        types = {
            '/chatter': 'std_msgs/msg/String',
            '/robot_1/cmd_vel': 'geometry_msgs/msg/Twist',
            '/sim/body_states': 'bridge_interfaces/msg/BodyStates',
        }
        with BagWriter(path, typestore) as writer:
            for topic in topics:
                qos = [QosSpec('keep_last', 1, 'reliable', 'transient_local')] if topic == '/chatter' else [
                    QosSpec('keep_last', 10, 'reliable', 'volatile')]
                writer.add_topic(topic, types[topic], qos)
            for i in range(n):
                t = t0_ns + i * period_ns
                msgs = {
                    '/chatter': typestore.types['std_msgs/msg/String'](data=f'msg {i}'),
                    '/robot_1/cmd_vel': twist_msg(typestore, 0.1 * i, -0.05 * i),
                    '/sim/body_states': body_states_msg(typestore, t, [
                        ('robot_1', 'mobile_robot', 1, 0.5 * i, 0.0, 0.1 * i),
                        ('robot_2', 'mobile_robot', 2, 0.0, 0.25 * i, 0.0),
                        ('box_1', 'box_obstacle', 3, 2.0, 2.0, 0.0),
                    ]),
                }
                for topic in topics:
                    raw = bytes(typestore.serialize_cdr(msgs[topic], types[topic]))
                    writer.write(topic, t, raw)
        return path

    make.typestore = typestore
    return make

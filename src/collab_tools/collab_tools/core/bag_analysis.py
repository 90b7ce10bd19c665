"""Reading rosbag2 bags and per-topic statistics, without ROS.

Messages are decoded with the message definitions stored in the bag itself
(rosbags' :class:`~rosbags.highlevel.AnyReader`), so custom types such as
``bridge_interfaces/msg/BodyStates`` decode without the ROS environment.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from rosbags.highlevel import AnyReader
from rosbags.typesys.store import Typestore

from .recording_loss import lost_on

__all__ = [
    'BagSummary',
    'TopicStats',
    'find_bags',
    'format_summary',
    'read_messages',
    'read_timestamps',
    'summarize_bag',
]

_METADATA = 'metadata.yaml'
_STORAGE_SUFFIXES = ('.mcap', '.db3')


@dataclass(frozen=True)
class TopicStats:
    topic: str
    type_name: str
    count: int
    first_ns: int
    last_ns: int
    rate_hz: float

    @property
    def duration_s(self) -> float:
        return (self.last_ns - self.first_ns) / 1e9 if self.count else 0.0


@dataclass(frozen=True)
class BagSummary:
    path: Path
    storage: str
    duration_s: float
    start_ns: int
    end_ns: int
    topics: list[TopicStats] = field(default_factory=list)
    message_count: int = 0
    #: Messages the recorder lost per topic ({} none; None: the bag has no recorder counts).
    lost: dict[str, int] | None = None
    #: What bag_reindex did to the bag after its recorder died (None: closed cleanly).
    repaired: str | None = None

    def topic(self, name: str) -> TopicStats:
        """The stats of one topic (KeyError if the bag does not have it)."""
        for stats in self.topics:
            if stats.topic == name:
                return stats
        raise KeyError(f'bag {self.path} has no topic {name!r}')

    @property
    def type_names(self) -> set[str]:
        return {t.type_name for t in self.topics}

    def topics_of_type(self, type_name: str) -> list[str]:
        return [t.topic for t in self.topics if t.type_name == type_name]


def rate_hz(count: int, first_ns: int, last_ns: int) -> float:
    """(count - 1) / (last - first) in Hz, 0.0 when undefined."""
    if count < 2 or last_ns <= first_ns:
        return 0.0
    return (count - 1) / ((last_ns - first_ns) / 1e9)


def _is_bag_dir(path: Path) -> bool:
    return path.is_dir() and (path / _METADATA).is_file()


def find_bags(path: Path) -> list[Path]:
    """Bag directories at ``path``: the bag itself, or every bag below a run directory (sorted).

    Raises FileNotFoundError when there is none.
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f'no bag found: {path} does not exist')
    if path.is_file():
        if path.name == _METADATA or path.suffix in _STORAGE_SUFFIXES:
            if _is_bag_dir(path.parent):
                return [path.parent]
        raise FileNotFoundError(
            f'no bag found: {path} is a file, not a rosbag2 directory (one with a {_METADATA})'
        )
    if _is_bag_dir(path):
        return [path]
    bags = sorted({m.parent for m in path.rglob(_METADATA) if m.is_file()})
    # A bag nested inside another bag's directory is not expected; keep the outer ones.
    outer = [b for b in bags if not any(o != b and o in b.parents for o in bags)]
    if outer:
        return outer
    unfinished = sorted(
        {f.parent for suffix in _STORAGE_SUFFIXES for f in path.rglob(f'*{suffix}') if f.is_file()}
    )
    hint = ''
    if unfinished:
        hint = (
            f'; {len(unfinished)} director{"y" if len(unfinished) == 1 else "ies"} hold bag data but no '
            f'{_METADATA} (recording not closed cleanly? `ros2 run collab_tools bag_reindex DIR` repairs it): '
            + ', '.join(str(u) for u in unfinished[:5])
        )
    raise FileNotFoundError(f'no bag found under {path} (looked for */{_METADATA}){hint}')


def _storage_id(path: Path) -> str:
    import yaml

    try:
        info = yaml.safe_load((path / _METADATA).read_text(encoding='utf-8'))
        return str(info['rosbag2_bagfile_information']['storage_identifier'])
    except Exception:  # noqa: BLE001 - fall back to the files present
        for suffix, name in (('.mcap', 'mcap'), ('.db3', 'sqlite3')):
            if any(path.glob(f'*{suffix}*')):
                return name
        return 'unknown'


def _open_reader(path: Path, typestore: Typestore | None) -> AnyReader:
    bags = find_bags(path)
    if len(bags) != 1:
        raise ValueError(f'{path} holds {len(bags)} bags; pass one bag directory: {[str(b) for b in bags]}')
    return AnyReader([bags[0]], default_typestore=typestore)


def read_timestamps(path: Path, topics: Iterable[str] | None = None) -> Iterator[tuple[str, int]]:
    """(topic, log time ns) of every message, in time order, without decoding."""
    with _open_reader(path, None) as reader:
        connections = _select(reader, topics)
        if topics is not None and not connections:
            return
        for connection, timestamp, _raw in reader.messages(connections=connections):
            yield connection.topic, timestamp


def _select(reader: AnyReader, topics: Iterable[str] | None) -> list:
    if topics is None:
        return list(reader.connections)
    wanted = {topics} if isinstance(topics, str) else set(topics)
    return [c for c in reader.connections if c.topic in wanted]


def summarize_bag(path: Path) -> BagSummary:
    """Per-topic counts, first/last log times and rates, read from the bag itself."""
    bag = find_bags(Path(path))
    if len(bag) != 1:
        raise ValueError(f'{path} holds {len(bag)} bags; pass one bag directory')
    bag_path = bag[0]
    with AnyReader([bag_path]) as reader:
        types: dict[str, str] = {}
        for connection in reader.connections:
            types.setdefault(connection.topic, connection.msgtype)
        counts = {t: 0 for t in types}
        first: dict[str, int] = {}
        last: dict[str, int] = {}
        for connection, timestamp, _raw in reader.messages():
            topic = connection.topic
            counts[topic] += 1
            if topic not in first or timestamp < first[topic]:
                first[topic] = timestamp
            if topic not in last or timestamp > last[topic]:
                last[topic] = timestamp
    stats = [
        TopicStats(
            topic=topic,
            type_name=types[topic],
            count=counts[topic],
            first_ns=first.get(topic, 0),
            last_ns=last.get(topic, 0),
            rate_hz=rate_hz(counts[topic], first.get(topic, 0), last.get(topic, 0)),
        )
        for topic in sorted(types)
    ]
    total = sum(counts.values())
    start = min(first.values()) if first else 0
    end = max(last.values()) if last else 0
    custom = _custom_data(bag_path)
    return BagSummary(
        path=bag_path,
        storage=_storage_id(bag_path),
        duration_s=(end - start) / 1e9,
        start_ns=start,
        end_ns=end,
        topics=stats,
        message_count=total,
        lost=lost_on(custom),
        repaired=custom.get('reindexed'),
    )


def _custom_data(path: Path) -> dict:
    import yaml

    try:
        info = yaml.safe_load((path / _METADATA).read_text(encoding='utf-8'))['rosbag2_bagfile_information']
        return dict(info.get('custom_data') or {})
    except Exception:  # noqa: BLE001 - the bag opened; its custom_data is only extra information
        return {}


def read_messages(
    path: Path,
    topics: Iterable[str] | None = None,
    *,
    typestore: Typestore | None = None,
) -> Iterator[tuple[str, int, Any]]:
    """Yield (topic, log time ns, decoded message) in time order.

    Types come from the bag's own message definitions; ``typestore`` is only
    a fallback for bags that carry none.
    """
    with _open_reader(Path(path), typestore) as reader:
        connections = _select(reader, topics)
        if topics is not None and not connections:
            return
        for connection, timestamp, raw in reader.messages(connections=connections):
            yield connection.topic, timestamp, reader.deserialize(raw, connection.msgtype)


def _fmt_rate(rate: float) -> str:
    return f'{rate:.2f}'


def format_summary(summary: BagSummary) -> str:
    """Aligned text table: topic, type, count, rate (Hz), then the duration line."""
    header = ('topic', 'type', 'count', 'rate Hz')
    rows = [(t.topic, t.type_name, str(t.count), _fmt_rate(t.rate_hz)) for t in summary.topics]
    widths = [max(len(r[i]) for r in [header, *rows]) for i in range(4)]

    def line(row: tuple[str, str, str, str]) -> str:
        return '  '.join(
            [row[0].ljust(widths[0]), row[1].ljust(widths[1]), row[2].rjust(widths[2]), row[3].rjust(widths[3])]
        ).rstrip()

    out = [f'bag: {summary.path} ({summary.storage})', line(header), '  '.join('-' * w for w in widths)]
    out += [line(r) for r in rows]
    if not rows:
        out.append('(no topics)')
    out.append(
        f'duration: {summary.duration_s:.3f} s, {summary.message_count} messages on {len(summary.topics)} topics'
    )
    if summary.lost:
        out.append(f'LOST by the recorder: {sum(summary.lost.values())} messages ('
                   + ', '.join(f'{topic} {n}' for topic, n in sorted(summary.lost.items())) + ')')
    elif summary.lost is not None:
        out.append('lost by the recorder: none')
    if summary.repaired:
        out.append(f'repaired: {summary.repaired}')
    return '\n'.join(out)

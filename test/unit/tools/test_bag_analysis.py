from __future__ import annotations

import pytest

from collab_tools.core.bag_analysis import find_bags, format_summary, summarize_bag
from collab_tools.core.bag_types import build_typestore
from collab_tools.core.bag_writer import BagWriter


def _string_bag(path, stamps_by_topic):
    store = build_typestore(['std_msgs/msg/String'], prefixes=[])
    S = store.types['std_msgs/msg/String']
    with BagWriter(path, store) as w:
        for topic, stamps in stamps_by_topic.items():
            w.add_topic(topic, 'std_msgs/msg/String')
            for i, t in enumerate(stamps):
                w.write(topic, t, bytes(store.serialize_cdr(S(data=str(i)), 'std_msgs/msg/String')))
    return path


def test_find_bags_run_dir_with_two_bags(tmp_path):
    run = tmp_path / 'run'
    b2 = _string_bag(run / 'robots' / 'bag_b', {'/x': [1]})
    b1 = _string_bag(run / 'bag_a', {'/x': [1]})
    (run / 'notes').mkdir()
    assert find_bags(run) == sorted([b1, b2])
    assert find_bags(b1) == [b1]
    assert find_bags(b1 / 'metadata.yaml') == [b1]


def test_find_bags_none_raises_clearly(tmp_path):
    with pytest.raises(FileNotFoundError, match='no bag found'):
        find_bags(tmp_path)
    with pytest.raises(FileNotFoundError, match='does not exist'):
        find_bags(tmp_path / 'missing')
    broken = tmp_path / 'crashed_bag'
    broken.mkdir()
    (broken / 'crashed_bag_0.mcap').write_bytes(b'\x89MCAP0\r\n')
    with pytest.raises(FileNotFoundError, match='reindex'):
        find_bags(tmp_path)


def test_summary_rates_on_synthetic_timestamps(tmp_path):
    t0 = 5_000_000_000
    bag = _string_bag(tmp_path / 'bag', {
        '/ten_hz': [t0 + i * 100_000_000 for i in range(11)],       # 11 msgs over 1.0 s -> 10 Hz
        '/two_hz': [t0 + 250_000_000 + i * 500_000_000 for i in range(5)],  # 5 over 2.0 s -> 2 Hz
        '/once': [t0 + 700_000_000],
    })
    s = summarize_bag(bag)
    ten, two, once = s.topic('/ten_hz'), s.topic('/two_hz'), s.topic('/once')
    assert ten.count == 11 and ten.rate_hz == pytest.approx(10.0)
    assert (ten.first_ns, ten.last_ns) == (t0, t0 + 1_000_000_000)
    assert two.count == 5 and two.rate_hz == pytest.approx(2.0)
    assert once.count == 1 and once.rate_hz == 0.0
    assert s.start_ns == t0 and s.end_ns == t0 + 2_250_000_000
    assert s.duration_s == pytest.approx(2.25)
    assert s.message_count == 17
    assert [t.topic for t in s.topics] == sorted(['/ten_hz', '/two_hz', '/once'])

    text = format_summary(s)
    lines = text.splitlines()
    header = next(line for line in lines if line.startswith('topic'))
    assert 'type' in header and 'count' in header and 'rate Hz' in header
    row = next(line for line in lines if line.startswith('/ten_hz'))
    assert '10.00' in row and 'std_msgs/msg/String' in row
    # aligned: the type column starts at the same offset in every row
    rows = [line for line in lines if line.startswith('/')]
    assert len({r.index('std_msgs') for r in rows}) == 1
    assert len({len(r) for r in rows}) == 1  # right-aligned numbers end together
    assert 'duration: 2.250 s' in lines[-1]


def test_empty_bag_summary(tmp_path):
    bag = _string_bag(tmp_path / 'bag', {'/quiet': []})
    s = summarize_bag(bag)
    assert s.message_count == 0 and s.duration_s == 0.0
    assert s.topic('/quiet').count == 0 and s.topic('/quiet').rate_hz == 0.0
    assert '/quiet' in format_summary(s)

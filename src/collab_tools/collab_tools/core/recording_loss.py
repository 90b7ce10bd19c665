"""What a recording could not keep, counted per topic, and how deep its queues are.

A recorder that cannot keep up loses messages in its subscription queue: with KEEP_LAST the
middleware overwrites the oldest sample and tells nobody (Fast DDS raises no ``message_lost``
event for it; measured on the pinned wheels). Every DDS publisher numbers its samples, and
rclpy hands that number to a callback that takes the message info
(``publication_sequence_number``), so a gap in the numbers a subscription receives is exactly
what it lost, whatever the cause (queue overflow, best-effort transport loss). rosbag2 counts
the middleware's ``message_lost`` events and the messages its writer cache drops; the
recorder here counts the gaps, those events (some other rmw does raise them) and the messages
it failed to write. Per topic:

* ``received``: messages taken from the subscription; ``written``: messages in the bag;
* ``gaps``: messages the publishers sent after the first one received and the recorder never
  got (sequence gaps); ``reported_lost``: the middleware's message_lost total;
* ``write_failed``: messages received and not written (storage error);
* ``lost`` = max(gaps, reported_lost) + write_failed (a message lost in transport can show as
  both a gap and an event).

Each publisher numbers its own samples, so a topic with several publishers keeps one sequence
per publisher: a number continues the one whose last number is the closest below it, and starts
a new one when there are fewer sequences than publishers and continuing would leave a gap
(:class:`SequenceGaps`). With no loss that is exact; with loss on several interleaved
publishers it is a close estimate.

The recorder puts the counts into metadata.yaml's ``custom_data`` (``messages_lost``: the
total, ``recorder_counts``: JSON per topic) and into a status file in the bag directory, which
it rewrites as it records, so a bag repaired after ``kill -9`` still has the last counts.
"""
from __future__ import annotations

import json
import math
import os
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import yaml

__all__ = ['LossLedger', 'SequenceGaps', 'STATUS_FILE', 'TopicCounts', 'lost_on', 'queue_depth',
           'read_status', 'write_status']

STATUS_FILE = 'recorder_status.yaml'
#: Sequences kept per topic (a publisher that restarts begins a new one; the oldest go first).
MAX_SEQUENCES = 64


class SequenceGaps:
    """Messages missing between the sequence numbers one subscription received (module docstring)."""

    def __init__(self) -> None:
        self._last: list[int] = []

    def observe(self, number: int, publishers: int = 1) -> int:
        """Take a received sample's publication sequence number; the messages missing before it."""
        below = [i for i, last in enumerate(self._last) if last < number]
        best = max(below, key=lambda i: self._last[i]) if below else None
        gap = number - self._last[best] - 1 if best is not None else 0
        if best is None or (gap > 0 and len(self._last) < publishers):
            self._last.append(number)  # a publisher not seen before (or restarted)
            if len(self._last) > MAX_SEQUENCES:
                self._last.remove(min(self._last))
            return 0
        self._last[best] = number
        return gap


@dataclass
class TopicCounts:
    received: int = 0
    written: int = 0
    gaps: int = 0
    reported_lost: int = 0
    write_failed: int = 0

    @property
    def lost(self) -> int:
        return max(self.gaps, self.reported_lost) + self.write_failed


class LossLedger:
    """Per-topic counts of what a recorder received, wrote and lost."""

    def __init__(self) -> None:
        self.topics: dict[str, TopicCounts] = {}
        self._sequences: dict[str, SequenceGaps] = {}

    def add_topic(self, topic: str) -> None:
        self.topics.setdefault(topic, TopicCounts())
        self._sequences.setdefault(topic, SequenceGaps())

    def received(self, topic: str, sequence_number: int | None, publishers: int = 1) -> None:
        counts = self.topics[topic]
        counts.received += 1
        if sequence_number:  # 0 / None: the rmw does not number its samples
            counts.gaps += self._sequences[topic].observe(int(sequence_number), publishers)

    def written(self, topic: str) -> None:
        self.topics[topic].written += 1

    def write_failed(self, topic: str) -> None:
        self.topics[topic].write_failed += 1

    def reported_lost(self, topic: str, total: int) -> None:
        """The middleware's running total of lost messages for the topic (a message_lost event)."""
        self.topics[topic].reported_lost = max(self.topics[topic].reported_lost, int(total))

    @property
    def total_lost(self) -> int:
        return sum(c.lost for c in self.topics.values())

    def lossy_topics(self) -> dict[str, int]:
        return {topic: c.lost for topic, c in sorted(self.topics.items()) if c.lost}

    def report(self) -> dict[str, dict[str, int]]:
        return {topic: {**asdict(c), 'lost': c.lost} for topic, c in sorted(self.topics.items())}

    def custom_data(self) -> dict[str, str]:
        """metadata.yaml custom_data entries (rosbag2 keeps only strings there)."""
        return {'messages_lost': str(self.total_lost),
                'recorder_counts': json.dumps(self.report(), sort_keys=True, separators=(',', ':'))}


def lost_on(custom_data: dict[str, Any] | None, topics: list[str] | None = None) -> dict[str, int] | None:
    """Messages lost per topic (only topics that lost some) from a bag's custom_data; ``topics``:
    only these (None: all). None when the bag has no recorder counts (not recorded here)."""
    text = (custom_data or {}).get('recorder_counts')
    if not text:
        return None
    try:
        counts = json.loads(text)
    except (TypeError, ValueError):
        return None
    wanted = counts if topics is None else {t: counts[t] for t in topics if t in counts}
    return {topic: int(c.get('lost', 0)) for topic, c in wanted.items()
            if isinstance(c, dict) and int(c.get('lost', 0))}


def write_status(path: Path, custom_data: dict[str, str], state: str) -> None:
    """The recorder's status file (replaced at once): state and its custom_data so far."""
    tmp = path.with_name(path.name + '.tmp')
    tmp.write_text(yaml.safe_dump({'state': state, 'custom_data': custom_data}, sort_keys=False))
    os.replace(tmp, path)


def read_status(path: Path) -> dict[str, Any]:
    """A status file's content ({} when there is none or it does not parse)."""
    try:
        data = yaml.safe_load(Path(path).read_text())
    except (OSError, UnicodeDecodeError, yaml.YAMLError):
        return {}
    return data if isinstance(data, dict) else {}


def queue_depth(rate_hz: float, seconds: float, low: int, high: int) -> int:
    """Subscription depth holding ``seconds`` of a topic published at ``rate_hz``, within [low, high]."""
    if not (rate_hz > 0 and math.isfinite(rate_hz)):
        return low
    return max(low, min(high, math.ceil(rate_hz * seconds)))

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
* ``drained``: messages taken after the stop signal, from what the queues still held (the drain);
* ``drain_left``: messages published before the stop that were still queued when the drain hit its
  bound (counted, not written; at least that many: counting is bounded too);
* ``lost`` = max(gaps, reported_lost) + write_failed + drain_left (a message lost in transport can
  show as both a gap and an event).

A stopping recorder drains (:class:`DrainRule`): a slow recorder is seconds behind a flood, and
what its queues hold was never taken, so no sequence gap shows it.

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

__all__ = ['DrainRule', 'LossLedger', 'SequenceGaps', 'STATUS_FILE', 'TopicCounts', 'lost_on', 'queue_depth',
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
    drained: int = 0
    drain_left: int = 0
    superseded: int = 0   # gaps and message_lost on a latched depth-1 topic: the publisher replaced them itself

    @property
    def lost(self) -> int:
        return max(self.gaps, self.reported_lost) + self.write_failed + self.drain_left


class LossLedger:
    """Per-topic counts of what a recorder received, wrote and lost."""

    def __init__(self) -> None:
        self.topics: dict[str, TopicCounts] = {}
        self._sequences: dict[str, SequenceGaps] = {}
        self._received_at_stop: dict[str, int] = {}
        self._latest_only: set[str] = set()
        self._reported_superseded: dict[str, int] = {}  # latched topics: message_lost totals seen

    def add_topic(self, topic: str, latest_only: bool = False) -> None:
        """latest_only: every publisher keeps only its newest sample (latched, depth 1), so a sample
        it replaced before the recorder took it is superseded by its own contract, not lost."""
        self.topics.setdefault(topic, TopicCounts())
        self._sequences.setdefault(topic, SequenceGaps())
        if latest_only:
            self._latest_only.add(topic)

    def received(self, topic: str, sequence_number: int | None, publishers: int = 1) -> None:
        counts = self.topics[topic]
        counts.received += 1
        if sequence_number:  # 0 / None: the rmw does not number its samples
            missed = self._sequences[topic].observe(int(sequence_number), publishers)
            if topic in self._latest_only:
                counts.superseded += missed
            else:
                counts.gaps += missed

    def drain_started(self) -> None:
        self._received_at_stop = {topic: c.received for topic, c in self.topics.items()}

    def drain_ended(self, left: dict[str, int]) -> None:
        """``left``: per topic, the messages published before the stop still queued at the drain's bound."""
        for topic, counts in self.topics.items():
            counts.drained = counts.received - self._received_at_stop.get(topic, 0)
            counts.drain_left = left.get(topic, 0)

    def drain_incomplete(self) -> dict[str, TopicCounts]:
        return {topic: c for topic, c in sorted(self.topics.items()) if c.drain_left}

    def written(self, topic: str) -> None:
        self.topics[topic].written += 1

    def write_failed(self, topic: str) -> None:
        self.topics[topic].write_failed += 1

    def reported_lost(self, topic: str, total: int) -> None:
        """The middleware's running total of lost messages for the topic (a message_lost event).

        On a latched depth-1 topic the event means what a gap means there: a reliable writer
        announced (DDS GAP) samples its one-sample history had already replaced, e.g. the ones
        published before a late-joining recorder matched. Superseded, not lost."""
        counts = self.topics[topic]
        if topic in self._latest_only:
            new = int(total) - self._reported_superseded.get(topic, 0)
            if new > 0:
                counts.superseded += new
                self._reported_superseded[topic] = int(total)
            return
        counts.reported_lost = max(counts.reported_lost, int(total))

    @property
    def total_lost(self) -> int:
        return sum(c.lost for c in self.topics.values())

    def lossy_topics(self) -> dict[str, int]:
        return {topic: c.lost for topic, c in sorted(self.topics.items()) if c.lost}

    def loss_lines(self, drain_timeout: float) -> list[str]:
        """What the recorder logs as errors when the bag closes (nothing when nothing was lost)."""
        lines = [f'{topic}: DRAIN INCOMPLETE, {c.drained} taken after the stop, at least {c.drain_left} '
                 f'still queued at drain_timeout ({drain_timeout:g} s)' for topic, c in self.drain_incomplete().items()]
        lossy = self.lossy_topics()
        if lossy:
            lines.append(f'{self.total_lost} message(s) LOST (not in the bag): ' + ', '.join(
                f'{topic}: {n} of {n + self.topics[topic].written}' for topic, n in lossy.items()))
        return lines

    def report(self) -> dict[str, dict[str, int]]:
        return {topic: {**asdict(c), 'lost': c.lost} for topic, c in sorted(self.topics.items())}

    def custom_data(self) -> dict[str, str]:
        """metadata.yaml custom_data entries (rosbag2 keeps only strings there)."""
        return {'messages_lost': str(self.total_lost),
                'recorder_counts': json.dumps(self.report(), sort_keys=True, separators=(',', ':'))}


class DrainRule:
    """When a stopping recorder has taken what its queues held.

    It keeps taking until no message published before the stop has come for ``quiet_period``
    seconds (done), or ``timeout`` seconds after the stop (timed out: whatever is still queued is
    lost). Messages published after the stop do not keep it going (a steady topic never goes quiet).
    Times in seconds, any monotonic clock."""

    def __init__(self, quiet_period: float, timeout: float, now: float) -> None:
        self.quiet_period, self.timeout = quiet_period, timeout
        self.started = self.last_taken = now

    def took(self, now: float) -> None:
        """A message published before the stop was taken."""
        self.last_taken = now

    def quiet(self, now: float) -> bool:
        return now - self.last_taken >= self.quiet_period

    def timed_out(self, now: float) -> bool:
        return not self.quiet(now) and now - self.started >= self.timeout

    def done(self, now: float) -> bool:
        return self.quiet(now) or self.timed_out(now)

    def wait(self, now: float) -> float:
        """How long the next wait for a message may block (never past quiet or the bound)."""
        return max(0.0, min(self.last_taken + self.quiet_period, self.started + self.timeout) - now)


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

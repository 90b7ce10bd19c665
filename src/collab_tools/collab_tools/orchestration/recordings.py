"""What a session does with its recorders' bags once the nodes have stopped.

A bag whose recorder died (``kill -9``, a crash: no metadata.yaml, an MCAP file with no
summary) is repaired as ``ros2 run collab_tools bag_reindex`` does it; then the recorder's loss
counts (metadata.yaml ``custom_data``, core.recording_loss) are read: messages lost on the
experiment's analysis topics (all recorded topics when it names none) fail the session
(exit code 5, ``session.EXIT_MESSAGES_LOST``).
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import yaml


@dataclass
class Recording:
    bag: Path
    analysis_topics: list[str] | None = None   # None: every recorded topic counts
    repaired: str | None = None                # what the repair did, if it ran
    lost: dict[str, int] = field(default_factory=dict)   # analysis topics that lost messages
    problem: str | None = None                 # the bag could not be repaired or read

    def summary(self) -> dict:
        return {'bag': str(self.bag), 'analysis_topics': self.analysis_topics, 'repaired': self.repaired,
                'messages_lost': self.lost, 'problem': self.problem}


def finish_recording(recording: Recording, log: Callable[[str], None]) -> None:
    """Repair the bag if its recorder died, then read what it lost (into ``recording``)."""
    from ..core.bag_repair import RepairError, needs_repair, repair_bag
    from ..core.recording_loss import lost_on

    bag = recording.bag
    if not bag.is_dir():
        return  # the recorder never started a bag (it failed at start: reported as a failed node)
    try:
        if needs_repair(bag):
            report = repair_bag(bag)
            recording.repaired = report.describe()
            log(f'[session] recorder died, bag repaired: {recording.repaired}')
        info = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    except (RepairError, OSError, yaml.YAMLError, KeyError, TypeError) as error:
        recording.problem = f'{type(error).__name__}: {error}'
        log(f'[session] bag {bag}: {recording.problem}')
        return
    lost = lost_on(info.get('custom_data'), recording.analysis_topics)
    recording.lost = lost or {}
    if lost:
        log(f'[session] bag {bag}: messages LOST on analysis topics: '
            + ', '.join(f'{topic} {n}' for topic, n in sorted(lost.items())))

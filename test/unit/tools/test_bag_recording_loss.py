"""recording_loss: sequence gaps per publisher, the ledger's counts, queue depths; the session's
end-of-run step repairs a dead recorder's bag and fails on lost analysis messages."""
from __future__ import annotations

import json
import shutil

import pytest
import yaml

from collab_tools.core.bag_types import build_typestore
from collab_tools.core.bag_writer import BagWriter, QosSpec
from collab_tools.core.recording_loss import (STATUS_FILE, DrainRule, LossLedger, SequenceGaps, lost_on,
                                              queue_depth, read_status, write_status)
from collab_tools.core.tool_settings import RECORDER_SETTINGS, parse_topic_rates
from collab_tools.orchestration.recordings import Recording, finish_recording


def test_one_publisher_gaps_are_exact():
    gaps = SequenceGaps()
    assert [gaps.observe(n) for n in (4, 5, 6, 9, 10, 20)] == [0, 0, 0, 2, 0, 9]


def test_interleaved_publishers_without_loss_count_nothing():
    gaps = SequenceGaps()
    # Two publishers, the second one ahead and first heard after the first one (a late joiner).
    a, b = range(5, 105), range(7, 107)
    order = [n for pair in zip(a, b) for n in pair]
    assert sum(gaps.observe(n, publishers=2) for n in order) == 0


def test_interleaved_publishers_with_loss():
    gaps = SequenceGaps()
    a = [n for n in range(1, 101) if n % 10]        # 9 lost between received ones (100: after the last)
    b = [n for n in range(1, 101) if n not in (50, 51)]  # 2 lost
    order = sorted([(i / len(a), n) for i, n in enumerate(a)] + [(i / len(b) + 1e-6, n) for i, n in enumerate(b)])
    assert sum(gaps.observe(n, publishers=2) for _, n in order) == 11


def test_restarted_publisher_starts_a_new_sequence():
    gaps = SequenceGaps()
    assert sum(gaps.observe(n) for n in (1, 2, 3, 1, 2, 3)) == 0


def test_ledger_counts_and_custom_data():
    ledger = LossLedger()
    for topic in ('/a', '/b'):
        ledger.add_topic(topic)
    for n in (1, 2, 3, 7):
        ledger.received('/a', n)
        ledger.written('/a')
    ledger.received('/b', None)  # an rmw without sequence numbers: counted, no gap
    ledger.write_failed('/b')
    ledger.reported_lost('/b', 2)
    assert ledger.topics['/a'].lost == 3 and ledger.topics['/b'].lost == 3
    custom = ledger.custom_data()
    assert custom['messages_lost'] == '6'
    assert json.loads(custom['recorder_counts'])['/a'] == {'received': 4, 'written': 4, 'gaps': 3,
                                                           'reported_lost': 0, 'write_failed': 0, 'drained': 0,
                                                           'drain_left': 0, 'superseded': 0, 'lost': 3}
    assert lost_on(custom) == {'/a': 3, '/b': 3}
    assert lost_on(custom, ['/a', '/c']) == {'/a': 3}
    assert lost_on({}) is None and lost_on({'recorder_counts': 'not json'}) is None


def test_drain_ends_when_quiet_or_at_its_bound():
    rule = DrainRule(quiet_period=0.3, timeout=2.0, now=10.0)
    assert not rule.done(10.2) and rule.wait(10.2) == pytest.approx(0.1)
    rule.took(10.25)                      # a queued message: the quiet period starts again
    assert not rule.done(10.5) and rule.done(10.55) and not rule.timed_out(10.55)
    busy = DrainRule(quiet_period=0.3, timeout=1.0, now=0.0)
    for t in (0.2, 0.4, 0.6, 0.8, 0.95):  # never quiet: the bound ends it, timed out
        busy.took(t)
    assert not busy.done(0.99) and busy.done(1.0) and busy.timed_out(1.0)
    assert busy.wait(0.99) == pytest.approx(0.01)
    assert DrainRule(0.3, 0.0, now=5.0).timed_out(5.0)  # drain_timeout 0: no drain


def test_a_drain_cut_short_is_lost_and_said_so():
    ledger = LossLedger()
    for topic in ('/fast', '/slow'):
        ledger.add_topic(topic)
    for n in range(1, 6):
        ledger.received('/fast', n)
        ledger.written('/fast')
    ledger.drain_started()
    for n in range(6, 9):                 # taken during the drain
        ledger.received('/fast', n)
        ledger.written('/fast')
    ledger.drain_ended({'/fast': 4})      # still queued at the bound
    fast = ledger.topics['/fast']
    assert (fast.drained, fast.drain_left, fast.lost, ledger.total_lost) == (3, 4, 4, 4)
    assert ledger.topics['/slow'].lost == 0 and list(ledger.drain_incomplete()) == ['/fast']
    assert lost_on(ledger.custom_data()) == {'/fast': 4}
    assert ledger.loss_lines(3.0) == [
        '/fast: DRAIN INCOMPLETE, 3 taken after the stop, at least 4 still queued at drain_timeout (3 s)',
        '4 message(s) LOST (not in the bag): /fast: 4 of 12']


def test_status_file_round_trip(tmp_path):
    write_status(tmp_path / STATUS_FILE, {'messages_lost': '1'}, 'recording')
    assert read_status(tmp_path / STATUS_FILE) == {'state': 'recording', 'custom_data': {'messages_lost': '1'}}
    assert read_status(tmp_path / 'missing.yaml') == {}


def test_queue_depth_from_rates():
    assert queue_depth(2000.0, 2.0, 100, 100_000) == 4000
    assert queue_depth(10.0, 2.0, 100, 100_000) == 100
    assert queue_depth(1e9, 2.0, 100, 100_000) == 100_000
    assert queue_depth(0.0, 2.0, 100, 100_000) == 100


def test_topic_rates_setting():
    assert parse_topic_rates(['', '/clock=500', 'cmd_vel=20.5']) == {'/clock': 500.0, 'cmd_vel': 20.5}
    for bad in ('/clock', '/clock=fast', '=5', '/clock=0'):
        with pytest.raises(ValueError, match='TOPIC=HZ'):
            parse_topic_rates([bad])
    with pytest.raises(Exception, match='parameter topic_rates'):
        RECORDER_SETTINGS.validate({'output': 'bag', 'topic_rates': ['/clock=-1']})


# ---- the session's end-of-run step ------------------------------------------------------------
def _bag(path, lost_on_a: int, killed: bool):
    typestore = build_typestore(['std_msgs/msg/String'])
    ledger = LossLedger()
    with BagWriter(path, typestore) as writer:
        for topic in ('/a', '/b'):
            writer.add_topic(topic, 'std_msgs/msg/String', [QosSpec('keep_last', 10, 'reliable', 'volatile')])
            ledger.add_topic(topic)
        raw = bytes(typestore.serialize_cdr(typestore.types['std_msgs/msg/String'](data='x'), 'std_msgs/msg/String'))
        for n in range(1, 21):
            for topic in ('/a', '/b'):
                if topic == '/a' and 1 < n <= 1 + lost_on_a:
                    continue
                writer.write(topic, n, raw)
                ledger.received(topic, n)
        writer.flush()
        write_status(path / STATUS_FILE, ledger.custom_data(), 'recording')
        if killed:
            shutil.copytree(path, path.with_name('killed'))
        for key, value in ledger.custom_data().items():
            writer.set_custom_data(key, value)
    return path.with_name('killed') if killed else path


def test_dead_recorders_bag_is_repaired_and_its_loss_read(tmp_path):
    bag = _bag(tmp_path / 'run', lost_on_a=3, killed=True)
    assert not (bag / 'metadata.yaml').exists()
    logged = []
    recording = Recording(bag)
    finish_recording(recording, logged.append)
    assert recording.repaired and 'reindexed' in recording.repaired
    assert recording.lost == {'/a': 3}
    assert any('LOST' in line for line in logged)
    info = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert info['message_count'] == 20 + 17


def test_loss_outside_the_analysis_topics_passes(tmp_path):
    bag = _bag(tmp_path / 'run', lost_on_a=2, killed=False)
    recording = Recording(bag, analysis_topics=['/b'])
    finish_recording(recording, lambda _line: None)
    assert recording.repaired is None and recording.lost == {}
    recording = Recording(bag)
    finish_recording(recording, lambda _line: None)
    assert recording.lost == {'/a': 2}


def test_session_exit_code_for_lost_messages(tmp_path):
    from collab_tools.orchestration.session import EXIT_MESSAGES_LOST, EXIT_OK, Session
    bag = _bag(tmp_path / 'run', lost_on_a=1, killed=False)
    with Session('loss', run_dir=tmp_path / 'session', log=None, domain_id=None) as session:
        session.add_recording('bag_recorder', bag)
        session.condition_met = True
    assert session.exit_code() == EXIT_MESSAGES_LOST
    summary = json.loads((tmp_path / 'session' / 'session.json').read_text())
    assert summary['recordings']['bag_recorder']['messages_lost'] == {'/a': 1}
    session.recordings['bag_recorder'].lost = {}
    assert session.exit_code() == EXIT_OK


def test_summary_and_report_show_the_loss_and_the_repair(tmp_path):
    from collab_tools.core.bag_analysis import format_summary, summarize_bag
    bag = _bag(tmp_path / 'run', lost_on_a=4, killed=True)
    finish_recording(Recording(bag), lambda _line: None)
    summary = summarize_bag(bag)
    assert summary.lost == {'/a': 4} and 'unclean stop' in summary.repaired
    text = format_summary(summary)
    assert 'LOST by the recorder: 4 messages (/a 4)' in text and 'repaired: ' in text


def test_gaps_on_a_latest_only_topic_are_superseded_not_lost():
    from collab_tools.core.recording_loss import LossLedger
    ledger = LossLedger()
    ledger.add_topic('/state', latest_only=True)
    ledger.add_topic('/events')
    for number in (1, 2, 5):   # 3 and 4 replaced by the publisher (latched, depth 1) / lost in transit
        ledger.received('/state', number)
        ledger.received('/events', number)
    assert ledger.topics['/state'].superseded == 2 and ledger.topics['/state'].lost == 0
    assert ledger.topics['/events'].gaps == 2 and ledger.topics['/events'].lost == 2
    assert ledger.lossy_topics() == {'/events': 2}


def test_message_lost_events_on_a_latest_only_topic_are_superseded_not_lost():
    # A late-joining recorder on a latched depth-1 topic gets a DDS GAP for the samples the writer
    # already replaced, and Fast DDS raises message_lost for it (seen in CI on /robot_1/coalition).
    from collab_tools.core.recording_loss import LossLedger
    ledger = LossLedger()
    ledger.add_topic('/state', latest_only=True)
    ledger.add_topic('/events')
    for topic in ('/state', '/events'):
        ledger.reported_lost(topic, 1)
        ledger.reported_lost(topic, 3)   # running totals, not increments
        ledger.reported_lost(topic, 3)
    assert ledger.topics['/state'].superseded == 3 and ledger.topics['/state'].lost == 0
    assert ledger.topics['/events'].reported_lost == 3 and ledger.topics['/events'].lost == 3
    assert ledger.lossy_topics() == {'/events': 3}

"""Orchestration library pieces that need no ROS graph: domains, process shutdown, files."""

import signal
import sys
import time
from types import SimpleNamespace

import pytest

from collab_tools.orchestration.domain import DomainUnavailableError, acquire_domain
from collab_tools.orchestration.experiment import ExperimentError, _finished_as_awaited, _matches, load_experiment
from collab_tools.orchestration.node_process import NodeProcess, NodeSpec

IGNORES_SIGINT = ('import signal, time\n'
                  'signal.signal(signal.SIGINT, signal.SIG_IGN)\n'
                  'print("rea" + "dy", flush=True)\n'
                  'time.sleep(60)\n')


@pytest.fixture(autouse=True)
def private_lock_dir(tmp_path, monkeypatch):
    monkeypatch.setenv('COLLAB_DOMAIN_LOCK_DIR', str(tmp_path / 'locks'))


def test_domain_ids_are_exclusive_until_released():
    first = acquire_domain(seed=1)
    second = acquire_domain(seed=1)
    assert first.domain_id != second.domain_id
    with pytest.raises(DomainUnavailableError, match='in use'):
        acquire_domain(first.domain_id)
    first.release()
    again = acquire_domain(first.domain_id)
    assert again.domain_id == first.domain_id
    again.release()
    second.release()


def test_a_shared_domain_excludes_only_exclusive_leases():
    first = acquire_domain(90, shared=True)
    second = acquire_domain(90, shared=True)
    with pytest.raises(DomainUnavailableError, match='in use'):
        acquire_domain(90)
    first.release()
    second.release()
    exclusive = acquire_domain(90)
    with pytest.raises(DomainUnavailableError, match='in use'):
        acquire_domain(90, shared=True)
    exclusive.release()


def test_domain_id_out_of_range_is_refused():
    with pytest.raises(DomainUnavailableError, match='domain_id'):
        acquire_domain(0)


def start_python(code: str, tmp_path) -> NodeProcess:
    spec = NodeSpec('none', 'python', name='stubborn')
    return NodeProcess(spec, [sys.executable, '-c', code], {}, tmp_path / 'stubborn.log')


def wait_for_log(process, text, timeout=10.0):
    # The log's first line echoes the command, so look at the lines after it.
    deadline = time.monotonic() + timeout
    while text not in process.log_path.read_text().splitlines()[1:]:
        assert time.monotonic() < deadline
        time.sleep(0.05)


def test_stop_escalates_when_sigint_is_ignored(tmp_path):
    process = start_python(IGNORES_SIGINT, tmp_path)
    wait_for_log(process, 'ready')
    code = process.stop(interrupt_timeout=0.5, terminate_timeout=2.0)
    assert code == -signal.SIGTERM
    assert process.outcome().startswith('terminated')
    assert process.ended_badly()


def test_stop_of_a_cooperative_process_is_clean(tmp_path):
    process = start_python('import time\nprint("rea" + "dy", flush=True)\ntime.sleep(60)\n',
                           tmp_path)
    wait_for_log(process, 'ready')
    process.stop(interrupt_timeout=5.0)
    assert process.outcome() == 'stopped cleanly'
    assert not process.ended_badly()


@pytest.mark.parametrize('text, message', [
    ('name: x\nnodes: []\nuntil: {seconds: 1}\n', 'experiment.nodes'),
    ('name: x\nnodes: [{package: a, executable: b}]\n', 'experiment.until'),
    ('name: x\nnodez: []\n', 'experiment.nodez: unknown field'),
    ('nodes: [{package: a, executable: b}]\nuntil: {exit: b}\n', 'experiment.name'),
])
def test_experiment_file_errors_name_the_field(tmp_path, text, message):
    path = tmp_path / 'experiment.yaml'
    path.write_text(text)
    with pytest.raises(ExperimentError, match=message.replace('[', r'\[')):
        load_experiment(path)


class _FinishedNode:
    def __init__(self, name, code):
        self.name, self._code = name, code

    def poll(self):
        return self._code


@pytest.mark.parametrize('until, node, expected', [
    ({'exit': 'host'}, _FinishedNode('host', 0), True),        # finished during an after_start wait
    ({'exit': 'host'}, _FinishedNode('host', 1), False),       # failed: an error, not completion
    ({'exit': 'host'}, _FinishedNode('bridge', 0), False),     # another node ended early
    ({'seconds': 5}, _FinishedNode('host', 0), False),
])
def test_only_the_awaited_node_exiting_cleanly_counts_as_completion(until, node, expected):
    assert _finished_as_awaited(until, node) is expected


def test_message_conditions_compare_equal_and_at_least_fields():
    msg = SimpleNamespace(robot='burger_1', version=5, header=SimpleNamespace(frame_id='map'))
    assert _matches(msg, {'robot': 'burger_1', 'header.frame_id': 'map'}, {'version': 5})
    assert not _matches(msg, {'robot': 'burger_1'}, {'version': 6})
    assert not _matches(msg, {'robot': 'burger_2'}, {'version': 1})

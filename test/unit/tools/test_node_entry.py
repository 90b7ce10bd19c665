"""collab_tools.node_entry: a stop signal while a node's module is still being imported ends the process
quietly with exit code 0; once imported, the node's own signal handling applies (Python's default here)."""

import signal
import subprocess
import sys
import textwrap
import time

import pytest

RUN = 'import sys; from collab_tools.node_entry import entry_point; sys.exit(entry_point("{module}")())'


@pytest.fixture
def modules(tmp_path):
    (tmp_path / 'slow_to_import.py').write_text(textwrap.dedent('''
        import time
        print('importing', flush=True)
        time.sleep(30)                      # a heavy import (numba kernels, scipy) stands here

        def main():
            return 5
        '''))
    (tmp_path / 'quick_node.py').write_text(textwrap.dedent('''
        import signal
        import time

        def main():
            print('running', signal.getsignal(signal.SIGINT) is signal.default_int_handler,
                  signal.getsignal(signal.SIGTERM) is signal.SIG_DFL, flush=True)
            try:
                time.sleep(30)
            except KeyboardInterrupt:
                print('the node handled SIGINT', flush=True)
                return 0
            return 3
        '''))
    return tmp_path


def start(modules, module):
    process = subprocess.Popen([sys.executable, '-c', RUN.format(module=module)], cwd=modules,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    first = process.stdout.readline()
    return process, first


@pytest.mark.parametrize('stop', [signal.SIGINT, signal.SIGTERM])
def test_a_stop_during_the_import_exits_0_without_a_traceback(modules, stop):
    process, first = start(modules, 'slow_to_import')
    assert first.strip() == 'importing'
    time.sleep(0.2)
    process.send_signal(stop)
    out, err = process.communicate(timeout=10)
    assert process.returncode == 0, err
    assert err == '' and out == ''


def test_after_the_import_the_nodes_own_handling_applies(modules):
    process, first = start(modules, 'quick_node')
    assert first.split() == ['running', 'True', 'True']       # Python's defaults are back for the node
    process.send_signal(signal.SIGINT)
    out, err = process.communicate(timeout=10)
    assert out.strip() == 'the node handled SIGINT' and process.returncode == 0, err


def test_the_functions_result_is_the_exit_code(modules):
    (modules / 'returns_seven.py').write_text('def main():\n    return 7\n')
    result = subprocess.run([sys.executable, '-c', RUN.format(module='returns_seven')], cwd=modules,
                            capture_output=True, text=True, timeout=30)
    assert result.returncode == 7 and result.stderr == ''

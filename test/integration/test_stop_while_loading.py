"""A node stopped while Python still imports its module (seconds: numpy, scipy, numba kernels, rclpy)
exits 0 without a traceback (collab_tools.node_entry), as a Ctrl-C of the orchestration right after it
started its nodes does. Before, the interrupt surfaced as a KeyboardInterrupt traceback and exit -2."""

import time

import pytest

from collab_tools.orchestration.node_process import NodeSpec

#: Each imports for 2-3 s on this machine (more under load): 0.4 s after the start is inside the import.
NODES = [NodeSpec('role_engine', 'role_engine', name='role_engine'),
         NodeSpec('sgcm', 'leader_planner', name='leader_planner', namespace='leader_arm'),
         NodeSpec('role_engine', 'role_player', name='role_player', namespace='burger_1')]


@pytest.mark.parametrize('spec', NODES, ids=[spec.executable for spec in NODES])
def test_a_node_stopped_while_loading_exits_0_without_a_traceback(session, spec):
    process = session.start(spec)
    time.sleep(0.4)
    assert process.poll() is None, process.log_tail()
    code = session.stop(process.label)
    log = process.log_path.read_text(errors='replace')
    assert code == 0 and 'Traceback' not in log, log[-2000:]

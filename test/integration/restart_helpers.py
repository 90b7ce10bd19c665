"""Fault injection for the restart tests (issue 16 item 5): a node killed as a crash ends it."""

import os
import signal


def kill_9(session, label: str):
    """SIGKILL the node ``label``'s process group (no shutdown, no last message). Its label is freed for a
    restart; the killed process stays in the session as ``<label>_killed`` (marked killed, so the
    session's liveness checks leave it be) with its log kept as ``<label>.killed.log``. Returns the
    killed process (its ``spec`` starts it again)."""
    process = session.nodes.pop(label)
    process.stopped_by = 'killed'
    os.killpg(process.popen.pid, signal.SIGKILL)
    process.popen.wait(10.0)
    process.stop()                         # closes its log
    process.log_path.rename(process.log_path.with_suffix('.killed.log'))
    session.nodes[f'{label}_killed'] = process
    return process

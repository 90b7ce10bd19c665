import re
import socket

import pytest

from collab_tools.orchestration.live import LiveView
from collab_tools.orchestration.session import Session


@pytest.fixture
def session(request, tmp_path):
    """An orchestration session in an isolated domain; nodes stop at test end."""
    label = re.sub(r'[^A-Za-z0-9_]+', '_', request.node.name)[:60]
    with Session(label, run_dir=tmp_path / 'run', log=None, stop_timeout=10.0) as s:
        yield s


@pytest.fixture
def port():
    """A free TCP port on 127.0.0.1 (for the live view's WebSocket server)."""
    with socket.socket() as probe:
        probe.bind(('127.0.0.1', 0))
        return probe.getsockname()[1]


@pytest.fixture
def live_session(request, tmp_path, port):
    """A session with the live view on ``port`` and the visualiser, as ``scripts/demo --live`` starts them
    (orchestration.live): they are its first nodes."""
    label = re.sub(r'[^A-Za-z0-9_]+', '_', request.node.name)[:60]
    with Session(label, run_dir=tmp_path / 'run', log=None, live=LiveView('127.0.0.1', port),
                 stop_timeout=10.0) as s:
        yield s


@pytest.fixture
def ros_node(session):
    """An rclpy node in the session's domain (spun in the background) for test pubs/subs."""
    return session.observer.node

import re

import pytest

from collab_tools.orchestration.session import Session


@pytest.fixture
def session(request, tmp_path):
    """An orchestration session in an isolated domain; nodes stop at test end."""
    label = re.sub(r'[^A-Za-z0-9_]+', '_', request.node.name)[:60]
    with Session(label, run_dir=tmp_path / 'run', log=None, stop_timeout=10.0) as s:
        yield s


@pytest.fixture
def ros_node(session):
    """An rclpy node in the session's domain (spun in the background) for test pubs/subs."""
    return session.observer.node

"""Shared pytest setup: the workspace's config dir and integration-test fixtures.

Integration tests start real nodes through the orchestration library, each test in
its own ROS domain with local-only discovery, and talk to them over real topics
through the session's observer node.
"""

from pathlib import Path

import pytest

WORKSPACE = Path(__file__).resolve().parents[1]
CONFIG_DIR = WORKSPACE / 'config'


@pytest.fixture
def config_dir() -> Path:
    return CONFIG_DIR


@pytest.fixture(autouse=True)
def _no_live_view_leaks(monkeypatch):
    """``--live`` turns the live view on for the rest of the process (orchestration.live.enable sets
    COLLAB_LIVE_VIEW, as a CLI run should); a test that parses ``--live`` in-process must not make
    every later test's sessions start a live view (CI: a secured session then asked for its enclave)."""
    from collab_tools.orchestration.live import ENVIRONMENT
    monkeypatch.delenv(ENVIRONMENT, raising=False)
    yield

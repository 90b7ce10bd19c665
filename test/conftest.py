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

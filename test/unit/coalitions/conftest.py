"""Make ``coalition_agents`` importable from the source tree when it is not installed, and load
the project's coalition config files once per session."""
from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

WORKSPACE = Path(__file__).resolve().parents[3]
PACKAGE_ROOT = WORKSPACE / 'src' / 'coalition_agents'
CONFIG = WORKSPACE / 'config' / 'coalitions'

if importlib.util.find_spec('coalition_agents') is None:
    sys.path.insert(0, str(PACKAGE_ROOT))

from coalition_agents.core import (  # noqa: E402  (after the path set-up above)
    load_capability_file, load_costs, load_library, load_tasks,
)


@pytest.fixture(scope='session')
def config_dir() -> Path:
    return CONFIG


@pytest.fixture(scope='session')
def library():
    return load_library(CONFIG / 'schemas.yaml')


@pytest.fixture(scope='session')
def costs():
    return load_costs(CONFIG / 'costs.yaml')


@pytest.fixture(scope='session')
def tasks(library):
    return load_tasks(CONFIG / 'tasks.yaml', library)


@pytest.fixture(scope='session')
def table3_robot(library):
    return load_capability_file(CONFIG / 'capabilities' / 'table3_robot.yaml', library).types['table3']


@pytest.fixture(scope='session')
def fig7_types(library):
    return load_capability_file(CONFIG / 'capabilities' / 'fig7_team.yaml', library).types


@pytest.fixture
def parse(library):
    """parse('F_R(X, local)', robots=('robot_1',)) -> InformationInstance."""
    def parse_text(text, robots=()):
        return library.parse(text, robots)
    return parse_text

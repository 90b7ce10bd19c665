"""Make ``sgcm`` importable from the source tree when the workspace is not built or sourced.

The SGCM core reads its YAML files with the shared field readers (``collab_tools.core.fields``) and
the tests build scenes with the bridge, so both source trees are added the same way.
"""
import importlib.util
import sys
from pathlib import Path

import pytest

WORKSPACE = Path(__file__).resolve().parents[3]
SRC = WORKSPACE / 'src'
CONFIG = WORKSPACE / 'config' / 'sgcm'

if importlib.util.find_spec('sgcm') is None:
    sys.path.insert(0, str(SRC / 'sgcm'))
if importlib.util.find_spec('pybullet_bridge') is None:
    sys.path.insert(0, str(SRC / 'pybullet_bridge'))
if importlib.util.find_spec('collab_tools') is None:  # the shared field readers and camera model
    sys.path.insert(0, str(SRC / 'collab_tools'))

from sgcm.core.rearrangement import RearrangementModel  # noqa: E402  (after the path set-up above)
from sgcm.core.task_config import load_cases, load_task, parse_case, parse_task  # noqa: E402

from sgcm_tasks import small_task_data  # noqa: E402


@pytest.fixture(scope='session')
def task_file() -> Path:
    return CONFIG / 'task.yaml'


@pytest.fixture(scope='session')
def cases_file() -> Path:
    return CONFIG / 'cases.yaml'


@pytest.fixture(scope='session')
def task(task_file):
    return load_task(task_file)


@pytest.fixture(scope='session')
def cases(cases_file, task):
    return load_cases(cases_file, task)


@pytest.fixture(scope='session')
def model(task):
    return RearrangementModel(task)


@pytest.fixture
def small_task():
    """small_task(rows, cols, colours={'red': [r, c]}, robots=..., ...) -> TaskConfig."""
    def build(*args, **kwargs):
        return parse_task(small_task_data(*args, **kwargs))
    return build


@pytest.fixture
def state_of():
    """state_of(model, {'red': [[row, col], ...], ...}) -> the model's state vector."""
    def build(model, objects):
        return model.state_of(parse_case({'name': 'state', 'objects': objects}, model.task))
    return build

"""The settings of the collaboration comparison (``roles-collab``): ``config/roles/collab.yaml``, validated.

Every scenario names a formation task file (``config/roles/formation_demo.yaml`` format: bridge
scenario, GP settings, replan period, conflict horizon) and optionally labeled goals; errors
name the field (RoleEngineError).
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import partial
from pathlib import Path

from collab_tools.core import fields as shared_fields
from collab_tools.core.fields import join_path

from ..core.errors import RoleEngineError
from ..core.formation_task import FormationTask, load_formation_task

# The shared field readers, raising RoleEngineError.
Fields = partial(shared_fields.Fields, error=RoleEngineError)
fail = partial(shared_fields.fail, error=RoleEngineError)
require_list = partial(shared_fields.require_list, error=RoleEngineError)
check_vector = partial(shared_fields.check_vector, error=RoleEngineError)
read_yaml_file = partial(shared_fields.read_yaml_file, error=RoleEngineError)

CONFIG_FILE = 'roles/collab.yaml'
METHODS = ('task_based', 'role_based')
TOP_LEVEL_KEYS = ('control_rate', 'integration_substeps', 'time_limit_factor', 'methods', 'scenarios')


@dataclass(frozen=True)
class CollabScenario:
    name: str
    task: FormationTask
    goals: dict[str, tuple[float, float]] | None     # labeled destinations, or None: formation + GRA


@dataclass(frozen=True)
class CollabConfig:
    source: Path
    control_rate: float
    integration_substeps: int
    time_limit_factor: float
    methods: tuple[str, ...]
    scenarios: tuple[CollabScenario, ...]


def load_collab_config(path: str | Path) -> CollabConfig:
    """The validated settings file; RoleEngineError naming the field."""
    path = Path(path)
    where = str(path)
    data = read_yaml_file(path, 'settings file')
    fields = Fields(data, where, allowed=TOP_LEVEL_KEYS)
    methods = require_list(fields.raw('methods', list(METHODS)), fields.path_of('methods'))
    for index, method in enumerate(methods):
        if method not in METHODS:
            raise fail(join_path(fields.path_of('methods'), index), f"must be one of {', '.join(METHODS)} "
                                                                     f'(got {method!r})')
    if not methods or len(set(methods)) != len(methods):
        raise fail(fields.path_of('methods'), 'must list each method at most once, at least one')
    entries = require_list(fields.raw('scenarios'), fields.path_of('scenarios'))
    if not entries:
        raise fail(fields.path_of('scenarios'), 'must list at least one scenario')
    scenarios = []
    for index, entry in enumerate(entries):
        at = join_path(fields.path_of('scenarios'), index)
        item = Fields(entry, at, allowed=('name', 'task', 'goals'))
        name = item.string('name')
        if name in [s.name for s in scenarios]:
            raise fail(item.path_of('name'), f'scenario {name!r} is listed twice')
        task_file = path.parent / item.string('task')
        try:
            task = load_formation_task(task_file)
        except ValueError as error:
            raise fail(item.path_of('task'), str(error)) from None
        goals = None
        if item.raw('goals', None) is not None:
            raw = item.raw('goals')
            if not isinstance(raw, dict) or not raw:
                raise fail(item.path_of('goals'), 'must map robot names to [x, y]')
            goals = {str(robot): check_vector(point, join_path(item.path_of('goals'), str(robot)), 2)
                     for robot, point in raw.items()}
        scenarios.append(CollabScenario(name, task, goals))
    return CollabConfig(
        source=path, control_rate=fields.number('control_rate', 10.0, gt=0.0),
        integration_substeps=fields.integer('integration_substeps', 5, ge=1),
        time_limit_factor=fields.number('time_limit_factor', 2.0, ge=1.0),
        methods=tuple(methods), scenarios=tuple(scenarios))


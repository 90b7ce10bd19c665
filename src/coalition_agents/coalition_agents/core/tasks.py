"""Tasks as data: the motor schema to activate and the information it requires.

"To use IQ-ASyMTRe for different tasks, one only needs to implement the behaviors (MSs)
and specify the required information" (paper, Section V-A-5). A task names its MS, the
information instances the MS needs (Table II for navigation), the information available
a priori (given to every robot of the team as zero-cost dummy sensors, Section IV-D) and,
optionally, the MS a helper activates while it serves information (footnote 14: "a cost to
activate a necessary MS (to maintain the relative position) on the robot that is chosen to
help"), charged once per helper robot in a coalition's cost.

Tasks file format (``config/coalitions/tasks.yaml``)::

    tasks:
      navigation:                      # task name, [A-Za-z][A-Za-z0-9_]*
        description: ''                # optional text
        motor_schema: navigate         # required: the MS the task activates (its cost: costs.yaml)
        requires: [F_G(local), F_M]    # required non-empty list of the MS's input instances;
                                       # variables shared between entries mean the same entity
        prior: [F_M]                   # optional fully instantiated instances known a priori
        helper_motor_schema: null      # optional MS name each helper robot runs (cost: costs.yaml)
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Sequence

from collab_tools.core.fields import Fields, load_config_file

from .capabilities import PRIOR_SENSOR
from .errors import ConfigError
from .information import Entity, InformationInstance, check_entity_name
from .schemas import SchemaKind, SchemaLibrary, SensorSchema, parse_field_instance


@dataclass(frozen=True)
class Task:
    name: str
    motor_schema: str
    requires: tuple[InformationInstance, ...]
    prior: tuple[InformationInstance, ...] = ()
    helper_motor_schema: str | None = None
    description: str = ''

    @property
    def prior_sensors(self) -> tuple[SensorSchema, ...]:
        """Dummy sensors that provide the a priori information (paper, Section IV-D)."""
        return tuple(SensorSchema(PRIOR_SENSOR, instance, SchemaKind.PRIOR) for instance in self.prior)

    def requirements(self, focus: Sequence[InformationInstance] | None = None) -> tuple[InformationInstance, ...]:
        """The MS inputs to reason about: all, or the ``focus`` subset (Table III looks at
        F_G(local) only: "F_A(local) ... is also ignored for conciseness")."""
        if focus is None:
            return self.requires
        missing = [str(instance) for instance in focus if instance not in self.requires]
        if missing:
            raise ConfigError(f"task {self.name}: {', '.join(missing)} is not an input of its motor schema "
                              f"(inputs: {', '.join(str(i) for i in self.requires)})")
        return tuple(focus)

    def with_objects(self, renaming: Mapping[str, str]) -> 'Task':
        """The same task about other objects, e.g. ``{'target': 'target_2'}`` for a second target."""
        def rename(instance: InformationInstance) -> InformationInstance:
            for old, new in renaming.items():
                instance = instance.replace_entity(Entity(old, robot=False), Entity(check_entity_name(new), robot=False))
            return instance
        return Task(self.name, self.motor_schema, tuple(rename(i) for i in self.requires),
                    tuple(rename(i) for i in self.prior), self.helper_motor_schema, self.description)


def task_from_dict(data: Any, library: SchemaLibrary, name: str, path: str) -> Task:
    section = Fields(data, path, ('description', 'motor_schema', 'requires', 'prior', 'helper_motor_schema'),
                     error=ConfigError)
    requires = tuple(parse_field_instance(library, value, item_path) for item_path, value in section.items('requires'))
    if not requires:
        raise ConfigError(f"{section.path_of('requires')}: a task must require at least one information instance")
    if len(set(requires)) != len(requires):
        raise ConfigError(f"{section.path_of('requires')}: an instance is listed twice")
    prior = []
    for item_path, value in section.items('prior', []):
        instance = parse_field_instance(library, value, item_path)
        if not instance.is_fully_instantiated or instance.has_local:
            raise ConfigError(f'{item_path}: a priori information must name objects only '
                              f'(no variables, no local robot), got {instance}')
        prior.append(instance)
    helper = section.raw('helper_motor_schema', None)
    return Task(name, section.name('motor_schema'), requires, tuple(prior),
                None if helper is None else section.name('helper_motor_schema'),
                section.string('description', '', allow_empty=True))


def tasks_from_dict(data: Any, library: SchemaLibrary, path: str = '') -> dict[str, Task]:
    section = Fields(data, path, ('tasks',), error=ConfigError)
    tasks = {name: task_from_dict(value, library, name, entry_path)
             for entry_path, name, value in section.entries('tasks')}
    if not tasks:
        raise ConfigError(f"{section.path_of('tasks')}: define at least one task")
    return tasks


def load_tasks(path: str | Path, library: SchemaLibrary) -> dict[str, Task]:
    """Read and validate a tasks file (errors name the file and the field)."""
    return load_config_file(path, lambda data: tasks_from_dict(data, library, ''), ConfigError)


__all__ = ['Task', 'load_tasks', 'task_from_dict', 'tasks_from_dict']

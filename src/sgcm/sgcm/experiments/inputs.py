"""What both SGCM experiments read: the task and its cases, as the options (``CASE_OPTIONS``) choose."""
from __future__ import annotations

from pathlib import Path

from collab_tools.experiments.api import ExperimentRequest
from collab_tools.experiments.sweep import select

from ..core.task_config import Case, TaskConfig, load_cases, load_task

def task_file(request: ExperimentRequest) -> Path:
    return Path(request.option('task', Path(request.config_dir) / 'sgcm' / 'task.yaml'))


def task_and_cases(request: ExperimentRequest) -> tuple[TaskConfig, list[Case]]:
    """The task (with --horizon) and the cases (--only); TaskConfigError / ValueError name bad input."""
    horizon = request.option('horizon')
    task = load_task(task_file(request), {'horizon': horizon} if horizon is not None else None)
    cases = load_cases(Path(request.option('cases', Path(request.config_dir) / 'sgcm' / 'cases.yaml')), task)
    return task, select(cases, request.option('only'), lambda c: c.name, 'case')

"""What both SGCM experiments read: the task and its cases, as the options (``CASE_OPTIONS``) choose.

A case may carry its own grid and goals (sgcm.core.task_config.case_task); :class:`CaseModels`
gives each case the game of its own task, built once per distinct task, and its FSE planner on the
path ``--planner`` names (sgcm.core.fse_compiled.make_planner: kernel or reference).
"""
from __future__ import annotations

from pathlib import Path

from collab_tools.experiments.api import ExperimentRequest
from collab_tools.experiments.sweep import select

from ..core.fse import FSEPlanner
from ..core.fse_compiled import CompiledFSEPlanner, make_planner
from ..core.rearrangement import RearrangementModel
from ..core.task_config import Case, TaskConfig, load_cases, load_task, task_of


def task_file(request: ExperimentRequest) -> Path:
    return Path(request.option('task', Path(request.config_dir) / 'sgcm' / 'task.yaml'))


def cases_file(request: ExperimentRequest) -> Path:
    return Path(request.option('cases', Path(request.config_dir) / 'sgcm' / 'cases.yaml'))


def planner_path(request: ExperimentRequest) -> str:
    """The leader's FSE path (--planner): kernel (default) or reference."""
    return request.option('planner', 'kernel')


def task_and_cases(request: ExperimentRequest) -> tuple[TaskConfig, list[Case]]:
    """The task (with --horizon) and the cases (--only); TaskConfigError / ValueError name bad input."""
    horizon = request.option('horizon')
    task = load_task(task_file(request), {'horizon': horizon} if horizon is not None else None)
    cases = load_cases(cases_file(request), task)
    return task, select(cases, request.option('only'), lambda c: c.name, 'case')


class CaseModels:
    """The game (and an FSE planner) of each case's own task; cases on the same task share them."""

    def __init__(self, task: TaskConfig, path: str = 'kernel', **planner_options):
        self.task = task
        self.planner_options = {'path': path, **planner_options}
        self._models: dict[int, tuple[RearrangementModel, CompiledFSEPlanner | FSEPlanner | None]] = {}

    def _entry(self, case: Case | None) -> tuple[TaskConfig, int]:
        task = self.task if case is None else task_of(case, self.task)
        return task, id(task)

    def model(self, case: Case | None = None) -> RearrangementModel:
        task, key = self._entry(case)
        if key not in self._models:
            self._models[key] = (RearrangementModel(task), None)
        return self._models[key][0]

    def planner(self, case: Case | None = None) -> CompiledFSEPlanner | FSEPlanner:
        model = self.model(case)
        key = self._entry(case)[1]
        if self._models[key][1] is None:
            self._models[key] = (model, make_planner(model, **self.planner_options))
        return self._models[key][1]

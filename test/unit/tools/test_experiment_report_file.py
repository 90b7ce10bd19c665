"""Every experiment's own Markdown report opens with its outcome line, the one ``scripts/report RUN`` puts first;
no experiment writes its report itself (only its paper notes), so none can skip that line."""
import re
import sys
import types
from pathlib import Path

from collab_tools.core.run_outcome import outcome_markdown, run_outcomes
from collab_tools.experiments.api import Experiment, ExperimentRequest, ExperimentResult, run_experiment

WORKSPACE = Path(__file__).resolve().parents[3]


def _experiment(monkeypatch, result: ExperimentResult) -> Experiment:
    module = types.ModuleType('fake_report_module')
    module.run = lambda request: result
    monkeypatch.setitem(sys.modules, 'fake_report_module', module)
    return Experiment('fake-report', 'Fake paper, Table 1', 'a test experiment', 'fake_report_module')


def test_the_report_opens_with_the_outcome_scripts_report_states(monkeypatch, tmp_path):
    table = '# Table 1\n\n| a | b |\n|---|---|\n| 1 | 2 |\n'
    experiment = _experiment(monkeypatch, ExperimentResult(
        passed=True, outcome='3 of 3 cases completed', report=table, acceptance={'every_case': True},
        report_file='table1.md'))
    run_experiment(experiment, ExperimentRequest(tmp_path, tmp_path / 'run'))
    lines = (tmp_path / 'run' / 'table1.md').read_text().splitlines()
    assert lines[0] == '- **fake-report: passed** — 3 of 3 cases completed'
    assert lines[:1] == outcome_markdown(run_outcomes(tmp_path / 'run'))   # what scripts/report RUN opens with
    assert lines[1] == '' and '\n'.join(lines[2:]) + '\n' == table          # the table follows, unchanged


def test_a_failed_check_is_named_in_the_first_line(monkeypatch, tmp_path):
    experiment = _experiment(monkeypatch, ExperimentResult(
        passed=False, outcome='box 0.9 m from its goal', report='| loss |\n',
        acceptance={'box_reached': False, 'no_conflicts': True}, report_file='summary.md'))
    run_experiment(experiment, ExperimentRequest(tmp_path, tmp_path / 'run'))
    first = (tmp_path / 'run' / 'summary.md').read_text().splitlines()[0]
    assert first == '- **fake-report: FAILED** — box 0.9 m from its goal (failed: box_reached)'


def test_without_a_report_file_no_markdown_is_written(monkeypatch, tmp_path):
    experiment = _experiment(monkeypatch, ExperimentResult(passed=True, outcome='ok', report='| a |\n'))
    run_experiment(experiment, ExperimentRequest(tmp_path, tmp_path / 'run'))
    assert sorted(p.name for p in (tmp_path / 'run').iterdir()) == ['results.json']


def test_experiments_leave_their_report_to_write_results():
    """An experiment module writes no Markdown file but its paper notes: its report goes through
    ExperimentResult.report_file, so it opens with the outcome line."""
    written = re.compile(r"""['"]([\w.-]+\.md)['"]\)\.write_text""")
    offenders = {}
    for module in sorted(WORKSPACE.glob('src/*/*/experiments/*.py')):
        names = [n for n in written.findall(module.read_text()) if 'notes' not in n]
        if names:
            offenders[module.relative_to(WORKSPACE).as_posix()] = names
    assert offenders == {}
    reports = {m.relative_to(WORKSPACE).as_posix() for m in WORKSPACE.glob('src/*/*/experiments/*.py')
               if "report_file='" in m.read_text()}
    assert len(reports) >= 10, reports   # every paper experiment's table or summary

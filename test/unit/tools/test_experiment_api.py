"""One signature and one results.json schema for every experiment, and the command that runs them."""
import argparse
import json
import math
import os
import subprocess
import sys
import types
from pathlib import Path

import pytest

from collab_tools.core.errors import ConfigurationError
from collab_tools.experiments.api import (RESERVED_KEYS, SCHEMA, Experiment, ExperimentRequest, ExperimentResult,
                                          Option, load_results, run_experiment)
from collab_tools.experiments.registry import all_experiments
from collab_tools.experiments.sweep import median, select, sweep

WORKSPACE = Path(__file__).resolve().parents[3]
PAPER_EXPERIMENTS = {'sgcm-table1', 'sgcm-disturbance', 'roles-table3', 'roles-table4', 'roles-collab',
                     'roles-formation', 'coalition-table3', 'coalition-fig7', 'coalition-fig9', 'coalition-boxpush'}


def _fake_module(monkeypatch, run):
    module = types.ModuleType('fake_experiment_module')
    module.run = run
    monkeypatch.setitem(sys.modules, 'fake_experiment_module', module)
    return Experiment('fake-table', 'Fake paper, Table 9', 'a test experiment', 'fake_experiment_module',
                      options=(Option('--size', 'how many', type=int, default=2),))


def test_results_json_has_the_schema_keys_then_the_data(monkeypatch, tmp_path):
    def run(request):
        (request.run_dir / 'table.md').write_text('| a |\n')
        return ExperimentResult(passed=True, outcome=f'{request.option("size")} rows', report='| a |',
                                acceptance={'rows_ok': True}, data={'rows': [1.5, math.inf]})

    experiment = _fake_module(monkeypatch, run)
    request = ExperimentRequest(config_dir=tmp_path, run_dir=tmp_path / 'run', seed=3, options={'size': 4})
    result = run_experiment(experiment, request)
    assert result.outcome == '4 rows'
    document = load_results(tmp_path / 'run')
    assert list(document)[:len(RESERVED_KEYS) + 1] == ['schema', 'experiment', 'paper', 'passed', 'outcome',
                                                      'options', 'seed', 'wall_s', 'acceptance', 'rows']
    assert document['schema'] == SCHEMA and document['paper'] == 'Fake paper, Table 9'
    assert document['acceptance'] == {'passed': True, 'rows_ok': True}
    assert document['rows'] == [1.5, None]   # inf is no JSON: written as null, never as Infinity
    json.loads((tmp_path / 'run' / 'results.json').read_text())


def test_an_experiment_must_return_a_result_and_keep_off_schema_keys(monkeypatch, tmp_path):
    experiment = _fake_module(monkeypatch, lambda request: {'passed': True})
    with pytest.raises(TypeError, match='not an ExperimentResult'):
        run_experiment(experiment, ExperimentRequest(tmp_path, tmp_path / 'run'))
    with pytest.raises(ValueError, match='schema keys'):
        ExperimentResult(passed=True, outcome='', data={'acceptance': {}})


def test_a_run_dir_without_schema_is_refused(tmp_path):
    (tmp_path / 'results.json').write_text('{"passed": true}')
    with pytest.raises(ConfigurationError, match='not a collab-experiment/1 document'):
        load_results(tmp_path)


def test_options_become_argparse_flags():
    parser = argparse.ArgumentParser()
    Option('--robots', 'column sizes', type=int, nargs='+', metavar='N').add_to(parser)
    Option('--mode', 'core or sim', choices=('core', 'sim'), default='core').add_to(parser)
    args = parser.parse_args(['--robots', '2', '10'])
    assert args.robots == [2, 10] and args.mode == 'core'


def test_sweep_selects_and_reports_progress():
    lines = []
    rows = sweep('t', [1, 2, 3], lambda x: x * x, log=lines.append, describe=lambda r: f'= {r}')
    assert rows == [1, 4, 9] and lines[1].startswith('[t 2/3] 2: = 4 (')
    assert lines[1].endswith(' s]') and 'elapsed' in lines[1] and 'ETA' in lines[1] and 'ETA' not in lines[2]
    assert select(['a', 'b'], ['b'], str, 'case') == ['b']
    with pytest.raises(ValueError, match='unknown case c'):
        select(['a', 'b'], ['c'], str, 'case')
    assert median([3, None, 1, 2]) == 2 and median([1, 2]) == 1.5 and median([]) is None


def test_every_paper_experiment_is_registered_with_its_reference():
    experiments = all_experiments()
    assert set(experiments) == PAPER_EXPERIMENTS
    for experiment in experiments.values():
        assert experiment.paper and experiment.module.split('.')[1] == 'experiments', experiment
    flags = {e.name: {o.flag for o in e.options} for e in experiments.values()}
    assert '--loss' in flags['coalition-fig7'] and '--loss' not in flags['coalition-table3']


def test_the_command_refuses_an_option_of_another_experiment(tmp_path):
    env = dict(os.environ, COLLAB_RUNS_DIR=str(tmp_path))
    done = subprocess.run([sys.executable, str(WORKSPACE / 'scripts' / 'experiment'), 'coalition-table3',
                           '--loss', '0.5'], capture_output=True, text=True, env=env, timeout=120)
    assert done.returncode == 2 and 'unrecognized arguments: --loss 0.5' in done.stderr
    assert not list(tmp_path.iterdir())   # nothing ran, no run directory left behind

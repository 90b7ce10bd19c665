"""Nothing lost: checkpoints, resume, Ctrl-C, no run directory for refused input; the inputs from the
command line (--config, --set) and options that do not apply refused (collab_tools.experiments and
scripts/experiment)."""
import json
import math
import os
import re
import subprocess
import sys
import types
from pathlib import Path

import pytest
import yaml

from collab_tools.core.errors import ConfigurationError
from collab_tools.experiments.api import (Experiment, ExperimentRequest, ExperimentResult, Option,
                                          inapplicable_options, run_experiment)
from collab_tools.experiments.checkpoint import Checkpoint
from collab_tools.experiments.inputs import apply_settings, parse_settings, plan_inputs
from collab_tools.experiments.progress import Progress, clock_text
from collab_tools.experiments.registry import all_experiments
from collab_tools.experiments.sweep import Steps, sweep

WORKSPACE = Path(__file__).resolve().parents[3]
CONFIG = WORKSPACE / 'config'
SMALL_TABLE4 = {'only': ['env_2'], 'sigma_obs': [0.1, 0.15], 'problems_per_environment': 2}   # 4 steps
SMALL_TABLE4_ARGS = ['roles-table4', '--only', 'env_2', '--set', 'sigma_obs=[0.1, 0.15]',
                     '--set', 'table4.problems_per_environment=2']
TIMING_KEYS = {'wall_s', 'wall_time_s', 'plan_seconds_total'}


def without_timing(document, run_dir):
    """results.json minus wall times, with the run directory's own path made neutral."""
    if isinstance(document, dict):
        return {k: without_timing(v, run_dir) for k, v in document.items() if k not in TIMING_KEYS}
    if isinstance(document, list):
        return [without_timing(v, run_dir) for v in document]
    if isinstance(document, str):
        return document.replace(str(run_dir), '<run>')
    return document


def table4_request(run_dir, on_step=None):
    return ExperimentRequest(CONFIG, Path(run_dir), options=SMALL_TABLE4, log=lambda _line: None,
                             checkpoint=Checkpoint(run_dir), on_step=on_step)


def interrupt_after(steps):
    finished = []

    def on_step(key):
        finished.append(key)
        if len(finished) == steps:
            raise KeyboardInterrupt
    return on_step


# ---------------------------------------------------------------------------------------- the acceptance
def test_interrupted_and_resumed_roles_table4_equals_an_uninterrupted_run(tmp_path):
    table4 = all_experiments()['roles-table4']
    run_experiment(table4, table4_request(tmp_path / 'whole'))
    whole = json.loads((tmp_path / 'whole' / 'results.json').read_text())

    resumed = tmp_path / 'resumed'
    with pytest.raises(KeyboardInterrupt):
        run_experiment(table4, table4_request(resumed, interrupt_after(2)))
    assert not (resumed / 'results.json').exists()
    assert len(Checkpoint(resumed).load('roles-table4')) == 2          # the finished steps are on disk

    solved = []
    run_experiment(table4, table4_request(resumed, on_step=solved.append))
    again = json.loads((resumed / 'results.json').read_text())
    assert len(solved) == 2                                               # only the two missing steps ran
    assert without_timing(again, resumed) == without_timing(whole, tmp_path / 'whole')
    assert again['gra']['process_roles'] == 4 * 6 and (resumed / 'table4_assignments.png').is_file()


# ---------------------------------------------------------------------------------------- checkpoints
def test_a_checkpoint_keeps_values_exactly_and_ignores_a_line_cut_short(tmp_path):
    checkpoint = Checkpoint(tmp_path)
    value = {'x': 0.1 + 0.2, 'nan': math.nan, 'inf': -math.inf, 'list': [1, None, True]}
    checkpoint.save('loop a', 'k1', value)
    with (tmp_path / 'partial' / 'loop_a.jsonl').open('a') as stream:
        stream.write('{"key": "k2", "val')                                # the run died while writing
    restored = checkpoint.load('loop a')
    assert list(restored) == ['k1'] and restored['k1']['x'] == 0.1 + 0.2
    assert math.isnan(restored['k1']['nan']) and restored['k1']['inf'] == -math.inf
    assert checkpoint.count() == 1 and Checkpoint(tmp_path / 'none').count() == 0


def test_steps_save_before_reporting_and_a_resumed_loop_skips_them(tmp_path):
    lines = []
    request = ExperimentRequest(CONFIG, tmp_path, log=lines.append, checkpoint=Checkpoint(tmp_path),
                                on_step=interrupt_after(2))
    with pytest.raises(KeyboardInterrupt):
        sweep('sq', [1, 2, 3], lambda x: x * x, request=request)
    ran = []
    request = ExperimentRequest(CONFIG, tmp_path, log=lines.append, checkpoint=Checkpoint(tmp_path))
    rows = sweep('sq', [1, 2, 3], lambda x: ran.append(x) or x * x, request=request)
    assert rows == [1, 4, 9] and ran == [3]
    assert lines[2].startswith('[sq] resumed: 2 of 3 steps restored') and lines[3].startswith('[sq 3/3] 3:')


def test_progress_lines_carry_elapsed_time_and_eta():
    lines = []
    progress = Progress('t', 4, lines.append, done=1, bar=False)
    progress.advance('a')
    assert lines[0].startswith('[t 2/4] a [elapsed ') and ', ETA ' in lines[0]
    assert progress.eta() is not None
    assert clock_text(42) == '42 s' and clock_text(185) == '3 min 05 s' and clock_text(3720) == '1 h 02 min'


def test_the_bar_is_tqdm_and_keeps_the_step_lines(capsys):
    with Steps('bar', 2, bar=True) as steps:
        steps.finish('a', 1, 'first')
        steps.finish('b', 2, 'second')
    out = capsys.readouterr()
    assert '[bar 1/2] first' in out.out and '[bar 2/2] second' in out.out
    assert 'bar' in out.err      # tqdm draws on stderr


# ---------------------------------------------------------------------------------------- refused input
def _fake(monkeypatch, run):
    module = types.ModuleType('fake_resume_module')
    module.run = run
    monkeypatch.setitem(sys.modules, 'fake_resume_module', module)
    return Experiment('fake', 'Fake paper', 'test', 'fake_resume_module')


def test_bad_input_removes_the_run_directory_it_was_made_for(monkeypatch, tmp_path):
    def refuse(request):
        raise ConfigurationError('table.size: must be >= 1')
    experiment = _fake(monkeypatch, refuse)
    with pytest.raises(ConfigurationError):
        run_experiment(experiment, ExperimentRequest(CONFIG, tmp_path / 'new', checkpoint=Checkpoint(tmp_path / 'new')),
                       remove_on_bad_input=True)
    assert not (tmp_path / 'new').exists()

    def refuse_late(request):
        request.checkpoint.save('loop', 'k', 1)
        raise ValueError('case 2: unknown')
    experiment = _fake(monkeypatch, refuse_late)
    with pytest.raises(ValueError):
        run_experiment(experiment, ExperimentRequest(CONFIG, tmp_path / 'kept', checkpoint=Checkpoint(tmp_path / 'kept')),
                       remove_on_bad_input=True)
    assert (tmp_path / 'kept' / 'partial').is_dir()      # finished steps are never thrown away


def test_options_that_do_not_apply_are_named():
    options = (Option('--mode', 'm', choices=('core', 'sim'), default='core'),
               Option('--loss', 'l', type=float, default=0.0, only_when=('mode', ('sim',))))
    assert inapplicable_options(options, {'mode': 'core', 'loss': 0.0}) == []
    assert inapplicable_options(options, {'mode': 'sim', 'loss': 0.5}) == []
    assert inapplicable_options(options, {'mode': 'core', 'loss': 0.5}) == ['--loss: only with --mode sim '
                                                                             '(got --mode core)']


def test_set_values_are_typed_and_unknown_keys_named():
    assert parse_settings(['a.b=2', 'c=[0.1, 0.2]', 'd=true', 'e=text']) == {'a.b': 2, 'c': [0.1, 0.2],
                                                                              'd': True, 'e': 'text'}
    for bad, message in (('a', 'expected key=value'), ('a..b=1', 'expected key=value'), ('a=', 'no value'),
                         ('a=[1', 'not YAML')):
        with pytest.raises(ConfigurationError, match=message):
            parse_settings([bad])
    data = {'table4': {'seed': 1, 'groups': [{'count': 3}]}, 'name': 'x'}
    assert apply_settings(data, {'table4.groups.0.count': 2}, 'f.yaml')['table4']['groups'][0]['count'] == 2
    with pytest.raises(ConfigurationError, match=r"--set table4\.sed: unknown key 'sed' at table4 of f\.yaml "
                                                 r"\(keys there: seed, groups\)"):
        apply_settings(data, {'table4.sed': 2}, 'f.yaml')
    with pytest.raises(ConfigurationError, match=r'a number there \(1\), not a text'):
        apply_settings(data, {'table4.seed': 'one'}, 'f.yaml')
    with pytest.raises(ConfigurationError, match=r'must be an index 0\.\.0'):
        apply_settings(data, {'table4.groups.3.count': 1}, 'f.yaml')


def test_config_and_set_make_a_run_configuration_without_touching_the_tracked_files(tmp_path):
    mine = tmp_path / 'mine'
    (mine / 'roles').mkdir(parents=True)
    (mine / 'roles' / 'collab.yaml').write_text('# my collab\n')
    plan = plan_inputs(CONFIG, mine, ['table4.seed=7'], name='roles-table4', main='roles/experiments.yaml')
    assert plan.record() == {'config': str(mine.resolve()), 'set': {'table4.seed': 7}}
    config_dir = plan.materialise(tmp_path / 'run')
    assert config_dir == tmp_path / 'run' / 'inputs' / 'config'
    edited = yaml.safe_load((config_dir / 'roles' / 'experiments.yaml').read_text())
    assert edited['table4']['seed'] == 7 and not (config_dir / 'roles' / 'experiments.yaml').is_symlink()
    assert (config_dir / 'roles' / 'collab.yaml').read_text() == '# my collab\n'          # the directory's file
    assert (config_dir / 'roles' / 'maps').resolve() == (CONFIG / 'roles' / 'maps').resolve()   # the tracked rest
    assert yaml.safe_load((CONFIG / 'roles' / 'experiments.yaml').read_text())['table4']['seed'] != 7
    assert plan_inputs(CONFIG, None, None, name='x', main=None).materialise(tmp_path / 'r2') == CONFIG

    with pytest.raises(ConfigurationError, match='neither a directory nor a file'):
        plan_inputs(CONFIG, tmp_path / 'missing', None, name='x', main='a.yaml')
    with pytest.raises(ConfigurationError, match='has no main input file'):
        plan_inputs(CONFIG, None, ['a=1'], name='x', main=None)
    with pytest.raises(ConfigurationError, match='--column and --set: both give the file'):
        plan_inputs(CONFIG, None, ['robots=[2]'], name='coalition-fig9', main='coalitions/scenarios/fig9_column.yaml',
                    own_option='column', own_option_given=True)


# ---------------------------------------------------------------------------------------- the command
def experiment_command(args, tmp_path, **env):
    return subprocess.run([sys.executable, str(WORKSPACE / 'scripts' / 'experiment'), *args], capture_output=True,
                          text=True, timeout=300, env=dict(os.environ, COLLAB_RUNS_DIR=str(tmp_path), **env))


def test_ctrl_c_keeps_the_finished_steps_and_says_how_to_resume(tmp_path):
    stopped = experiment_command(SMALL_TABLE4_ARGS, tmp_path, COLLAB_EXPERIMENT_INTERRUPT_AFTER='1')
    assert stopped.returncode == 130 and 'Traceback' not in stopped.stderr, stopped.stderr
    [run_dir] = tmp_path.iterdir()
    assert f'resume with: scripts/experiment roles-table4 --resume {run_dir}' in stopped.stderr
    assert json.loads((run_dir / 'run.json').read_text())['status'] == 'interrupted'
    assert len(Checkpoint(run_dir).load('roles-table4')) == 1

    changed = experiment_command(['roles-table4', '--resume', str(run_dir), '--only', 'env_1'], tmp_path)
    assert changed.returncode == 2 and "--only ['env_1'] (the run has ['env_2'])" in changed.stderr

    resumed = experiment_command(['roles-table4', '--resume', str(run_dir)], tmp_path)
    assert resumed.returncode == 0, resumed.stderr
    assert 'resumed: 1 of 4 steps restored' in resumed.stdout and '[roles-table4 2/4]' in resumed.stdout
    document = json.loads((run_dir / 'results.json').read_text())
    assert document['options']['set'] == {'sigma_obs': [0.1, 0.15], 'table4.problems_per_environment': 2}
    assert document['gra']['process_roles'] == 4 * 6 and list(tmp_path.iterdir()) == [run_dir]


@pytest.mark.parametrize('args, message', [
    (['roles-table4', '--set', 'table4.problems_per_environmnt=2'], "unknown key 'problems_per_environmnt'"),
    (['roles-table4', '--set', 'table4.problems_per_environment=0'], 'problems_per_environment'),
    (['roles-table4', '--config', '/no/such/dir'], 'neither a directory nor a file'),
    (['roles-table4', '--seed', '3'], 'unrecognized arguments: --seed 3'),
    (['coalition-table3', '--loss', '0.5'], 'unrecognized arguments: --loss 0.5'),
    (['coalition-fig7', '--loss', '0.5'], '--loss: only with --mode sim'),
    (['coalition-fig7', '--seed', '2'], '--seed: only with --mode sim'),
    (['sgcm-table1', '--mode', 'sim', '--failures'], '--failures: only with --mode core'),
    (['coalition-fig9', '--column', 'x.yaml', '--set', 'robots=[2]'], '--column and --set'),
    (['roles-table4', '--resume', '/no/such/run'], 'holds no readable run.json'),
    (['roles-table3', '--live'], 'unrecognized arguments: --live'),   # starts no nodes
    (['sgcm-table1', '--live'], '--live: only with --mode sim'),
])
def test_refused_input_exits_2_and_leaves_no_run_directory(tmp_path, args, message):
    done = experiment_command(args, tmp_path)
    assert done.returncode == 2 and message in done.stderr and 'Traceback' not in done.stderr, done.stderr
    assert not list(tmp_path.iterdir())


def test_help_shows_only_the_experiments_own_options():
    done = subprocess.run([sys.executable, str(WORKSPACE / 'scripts' / 'experiment'), 'coalition-table3', '--help'],
                          capture_output=True, text=True, timeout=120)
    flags = set(re.findall(r'^\s+(--[a-z-]+)', done.stdout, re.MULTILINE))
    assert done.returncode == 0 and {'--config', '--set', '--resume', '--run-dir'} <= flags
    assert not flags & {'--loss', '--mode', '--only', '--seed', '--robots', '--live'}


def test_a_loop_in_its_own_code_is_checkpointed_through_steps(tmp_path):
    calls = []
    with Steps('own', 2, checkpoint=Checkpoint(tmp_path), log=lambda _l: None) as steps:
        square = steps.checkpointed(lambda x: calls.append(x) or {'sq': x * x}, key=lambda x: f'x={x}')
        assert square(3) == {'sq': 9}
    with Steps('own', 2, checkpoint=Checkpoint(tmp_path), log=lambda _l: None) as steps:
        square = steps.checkpointed(lambda x: calls.append(x) or {'sq': x * x}, key=lambda x: f'x={x}')
        assert square(3) == {'sq': 9} and square(4) == {'sq': 16}
    assert calls == [3, 4]


def test_sgcm_table1_resumes_to_the_same_results(tmp_path):
    table1 = all_experiments()['sgcm-table1']
    options = {'mode': 'core', 'only': ['case_1', 'case_2', 'case_4'], 'planner': 'kernel'}

    def request(run_dir, on_step=None):
        return ExperimentRequest(CONFIG, run_dir, options=options, log=lambda _l: None,
                                 checkpoint=Checkpoint(run_dir), on_step=on_step)
    run_experiment(table1, request(tmp_path / 'whole'))
    with pytest.raises(KeyboardInterrupt):
        run_experiment(table1, request(tmp_path / 'resumed', interrupt_after(2)))
    run_experiment(table1, request(tmp_path / 'resumed'))
    documents = [json.loads((tmp_path / name / 'results.json').read_text()) for name in ('whole', 'resumed')]
    timing = TIMING_KEYS | {'planning_seconds'}

    def plain(document):
        if isinstance(document, dict):
            return {k: plain(v) for k, v in document.items() if k not in timing}
        return [plain(v) for v in document] if isinstance(document, list) else document
    assert plain(documents[0]) == plain(documents[1]) and len(documents[1]['cases']) == 3


def test_what_an_interrupted_step_left_is_set_aside_for_its_new_try(tmp_path):
    from collab_tools.experiments.checkpoint import fresh_step_dir

    step = tmp_path / 'case_2' / 'greedy'
    (step / 'bags' / 'sgcm').mkdir(parents=True)
    assert fresh_step_dir(tmp_path, step) == step and not step.exists()
    assert (tmp_path / 'partial' / 'interrupted' / 'case_2' / 'greedy' / 'bags' / 'sgcm').is_dir()
    step.mkdir()
    fresh_step_dir(tmp_path, step)                     # a second interruption: kept beside the first
    assert (tmp_path / 'partial' / 'interrupted' / 'case_2' / 'greedy-1').is_dir()
    assert fresh_step_dir(tmp_path, tmp_path / 'new') == tmp_path / 'new'   # nothing there: nothing moved

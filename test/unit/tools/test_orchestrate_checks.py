"""scripts/orchestrate refuses a bad experiment file with exit code 2 before any node starts: unknown
packages and executables (ament index), misspelt message/service types and fields, steps naming
nodes the file does not have (orchestration.experiment_checks). No node is started here."""
import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from collab_tools.orchestration.experiment import ExperimentError
from collab_tools.orchestration.experiment_checks import check_experiment

WORKSPACE = Path(__file__).resolve().parents[3]
CONFIG = WORKSPACE / 'config'
DRIVER = {'package': 'collab_tools', 'executable': 'scripted_driver', 'name': 'driver'}
DONE = {'message': {'topic': '/done', 'type': 'std_msgs/msg/Bool', 'equals': {'data': True}}}


def experiment_file(tmp_path, nodes=(DRIVER,), until=DONE, **more):
    path = tmp_path / 'experiment.yaml'
    path.write_text(yaml.safe_dump({'name': 'bad', 'nodes': list(nodes), 'until': until, **more}))
    return path


BAD_FILES = [
    (dict(nodes=[{'package': 'no_such_pkg', 'executable': 'x'}]),
     "experiment.nodes[0] (x): package 'no_such_pkg' is not in the ament index"),
    (dict(nodes=[{'package': 'collab_tools', 'executable': 'scripted_drivr'}]),
     "package 'collab_tools' has no executable 'scripted_drivr' (available: "),
    (dict(until={'message': {'topic': '/done', 'type': 'std_msgs/msg/Bol'}}),
     "experiment.until.message.type: interface type 'std_msgs/msg/Bol' is not installed"),
    (dict(until={'message': {'topic': '/done', 'type': 'std_msgs/msg/Bool', 'equals': {'date': True}}}),
     "experiment.until.message.equals.date: Bool has no field 'date' (fields: data)"),
    (dict(until={'exit': 'drivr'}), "experiment.until.exit: no node named 'drivr' (nodes: driver)"),
    (dict(until={'seconds': -1}), 'experiment.until.seconds: must be a number of seconds > 0'),
    (dict(after_start=[{'stop': 'bridge'}]), "experiment.after_start[0].stop: no node named 'bridge'"),
    (dict(after_start=[{'call': {'service': '/pause', 'type': 'std_srvs/srv/SetBol'}}]),
     "experiment.after_start[0].call.type: interface type 'std_srvs/srv/SetBol'"),
    (dict(after_start=[{'call': {'service': '/pause', 'type': 'std_srvs/srv/SetBool', 'request': {'dat': 1}}}]),
     "experiment.after_start[0].call.request.dat: SetBool_Request has no field 'dat' (fields: data)"),
    (dict(after_start=[{'wait': 1}]), 'experiment.after_start[0]: expected exactly one of wait_for_message, call'),
    (dict(nodes=[{**DRIVER, 'parameters': ['missing.yaml']}]),
     "experiment.nodes[0] (driver).parameters[0]: parameter file"),
    (dict(timeout='long'), 'experiment.timeout: must be a number of seconds > 0'),
    (dict(follow=[{'topic': '/done', 'type': 'std_msgs/msg/Bool', 'say': 'done: {dat}'}]),
     "experiment.follow[0].say: 'done: {dat}' does not fit Bool"),
    (dict(follow=[{'topic': '/done', 'type': 'std_msgs/msg/Bool', 'say': 'x', 'every': 2}]),
     'experiment.follow[0].every: unknown field'),
    (dict(follow=[{'topic': '/done', 'type': 'std_msgs/msg/Bool', 'say': 'x', 'when': {'date': True}}]),
     "experiment.follow[0].when.date: Bool has no field 'date'"),
]


@pytest.mark.parametrize('fields, message', BAD_FILES)
def test_a_bad_field_is_named(tmp_path, fields, message):
    with pytest.raises(ExperimentError) as error:
        check_experiment(experiment_file(tmp_path, **fields), CONFIG)
    assert message in str(error.value)


def test_a_misspelt_type_gets_a_suggestion(tmp_path):
    with pytest.raises(ExperimentError, match=r'did you mean std_msgs/msg/Bool\?'):
        check_experiment(experiment_file(tmp_path, until={'message': {'topic': '/d', 'type': 'std_msgs/msg/Bol'}}),
                         CONFIG)


def test_the_tracked_experiment_files_pass():
    for path in sorted((CONFIG / 'experiments').glob('*.yaml')):
        assert check_experiment(path, CONFIG)['name'], path


@pytest.mark.parametrize('fields, message', [BAD_FILES[0], BAD_FILES[2], BAD_FILES[6]])
def test_orchestrate_exits_2_before_any_node_starts(tmp_path, fields, message):
    run_dir = tmp_path / 'run'
    done = subprocess.run([sys.executable, str(WORKSPACE / 'scripts' / 'orchestrate'),
                           str(experiment_file(tmp_path, **fields)), '--run-dir', str(run_dir)],
                          capture_output=True, text=True, timeout=120, env=dict(os.environ))
    assert done.returncode == 2 and message in done.stderr, done.stderr
    assert 'Traceback' not in done.stderr and '[session]' not in done.stdout + done.stderr
    assert not run_dir.exists()


def test_follow_lines_format_the_message_fields():
    from std_msgs.msg import Header
    from collab_tools.orchestration.experiment import _MessageFields

    header = Header(frame_id='map')
    header.stamp.sec = 7
    assert 'frame {frame_id} at {stamp.sec} s'.format_map(_MessageFields(header)) == 'frame map at 7 s'


def test_a_follow_entry_passes_the_checks(tmp_path):
    follow = [{'topic': '/done', 'type': 'std_msgs/msg/Bool', 'say': 'done: {data}', 'when': {'data': True}}]
    assert check_experiment(experiment_file(tmp_path, follow=follow), CONFIG)['follow'] == follow

"""Experiments split over two hosts (network namespaces joined by a veth pair).

The orchestrator runs on host A (as it would on the main machine) and starts some nodes on
host B through the experiment's `hosts`. With SUBNET discovery they meet; with the stock
local-only discovery the nodes on B are never discovered, and the run must fail (exit 4),
not end as a success.
"""
import json
import os
import subprocess
import sys
from pathlib import Path

import yaml

from netns_hosts import run_in, two_hosts

WORKSPACE = Path(__file__).resolve().parents[2]
CONFIG = WORKSPACE / 'config'


def orchestrate(hosts, experiment: dict, tmp_path: Path, timeout: float = 240.0) -> subprocess.CompletedProcess:
    path = tmp_path / 'experiment.yaml'
    path.write_text(yaml.safe_dump(experiment, sort_keys=False))
    return run_in(hosts.a, [sys.executable, str(WORKSPACE / 'scripts' / 'orchestrate'), str(path),
                            '--run-dir', str(tmp_path / 'run')], timeout=timeout, env=dict(os.environ))


def demo_on_two_hosts(hosts, discovery, discovery_timeout=60.0) -> dict:
    experiment = yaml.safe_load((CONFIG / 'experiments' / 'demo_mobile.yaml').read_text())
    experiment.pop('record')
    experiment['discovery'] = discovery
    experiment['discovery_timeout'] = discovery_timeout
    experiment['hosts'] = {'robot_host': {'netns': hosts.b}}
    for node in experiment['nodes']:
        if node['executable'] == 'scripted_driver':
            node['host'] = 'robot_host'
    return experiment


def test_driver_on_another_host_drives_the_simulation(tmp_path):
    with two_hosts('drive') as hosts:
        result = orchestrate(hosts, demo_on_two_hosts(hosts, {'range': 'SUBNET'}), tmp_path)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    session = yaml.safe_load((tmp_path / 'run' / 'session.json').read_text())
    assert session['condition_met'] is True
    assert 'ip' in session['nodes']['scripted_driver']['command'][0]


def test_local_only_discovery_across_hosts_fails_the_run(tmp_path):
    with two_hosts('local') as hosts:
        result = orchestrate(hosts, demo_on_two_hosts(hosts, {'range': 'LOCALHOST'}, discovery_timeout=8.0),
                             tmp_path, timeout=120.0)
    assert result.returncode == 4, result.stdout[-3000:] + result.stderr[-3000:]
    session = yaml.safe_load((tmp_path / 'run' / 'session.json').read_text())
    assert session['not_discovered'] == ['/scripted_driver']
    assert session['condition_met'] is False


SGCM_SPLIT = '''
import sys
from pathlib import Path
from sgcm.core.task_config import load_cases, load_task
from sgcm.experiments.sim_runner import run_case
config, experiment, run_dir = map(Path, sys.argv[1:4])
task_file = config / 'sgcm' / 'task.yaml'
task = load_task(task_file)
case = next(c for c in load_cases(config / 'sgcm' / 'cases.yaml', task) if c.name == 'case_8')
result = run_case(task, task_file, case, run_dir, config, strategy='sgcm', experiment=experiment)
print(result.message)
sys.exit(result.exit_code if result.condition_met or result.exit_code else 1)
'''


def test_sgcm_case_with_the_follower_on_another_host(tmp_path):
    """Bridge and leader on host A, the follower arm's executor on host B: the case completes."""
    experiment = yaml.safe_load((CONFIG / 'experiments' / 'sgcm_case.yaml').read_text())
    experiment['discovery'] = {'range': 'SUBNET'}
    experiment['record']['topics'] = ['/sgcm/guidance', '/sgcm/follower_report']
    with two_hosts('sgcm') as hosts:
        experiment['hosts'] = {'follower_host': {'netns': hosts.b}}
        follower = next(n for n in experiment['nodes'] if n['executable'] == 'follower_executor')
        follower['host'] = 'follower_host'
        path = tmp_path / 'sgcm_split.yaml'
        path.write_text(yaml.safe_dump(experiment, sort_keys=False))
        result = run_in(hosts.a, [sys.executable, '-c', SGCM_SPLIT, str(CONFIG), str(path), str(tmp_path / 'run')],
                        timeout=600, env=dict(os.environ))
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    session = yaml.safe_load((tmp_path / 'run' / 'session.json').read_text())
    assert session['nodes']['follower_arm/follower_executor']['command'][:4] == ['ip', 'netns', 'exec', hosts.b]
    from collab_tools.core.bag_analysis import read_messages
    from sgcm.core.rearrangement import RearrangementModel
    from sgcm.core.task_config import load_task
    from sgcm.experiments.sim_runner import episode_from_bag
    bag = tmp_path / 'run' / 'bags' / 'sgcm'
    reports = [m for _, _, m in read_messages(bag, ['/sgcm/follower_report'])]
    assert reports, 'no follower report crossed the link'
    episode = episode_from_bag(RearrangementModel(load_task(CONFIG / 'sgcm' / 'task.yaml')), bag, 'sgcm')
    assert episode.completed


COALITION_SPLIT = '''
import json, sys
from pathlib import Path
from coalition_agents.core.sim_scenarios import COLUMN_TYPES, column_placements
from coalition_agents.experiments.coalition_bag import read_coalition_bag
from coalition_agents.experiments.column import COLUMN_CONFIG, column_result, load_column_config
from coalition_agents.experiments.sessions import AgentSetup, run_session
config, run_dir, host_b, discovery = Path(sys.argv[1]), Path(sys.argv[2]), sys.argv[3], sys.argv[4]
discovery_timeout = float(sys.argv[5])
column = load_column_config(config / 'coalitions' / COLUMN_CONFIG)
placements = column_placements(4, column.spacing_m)
setup = AgentSetup(leaders=(placements[-1].robot,), search_time_s=3.0, link_preset=column.link_preset,
                   timeout_s=120.0, host_processes=2, discovery={'range': discovery},
                   discovery_timeout_s=discovery_timeout, hosts={'helpers_host': {'netns': host_b}},
                   process_hosts=(None, 'helpers_host'))
result = run_session(run_dir, config, 'split_column', placements, COLUMN_TYPES, column.sensors, setup, log=print)
summary = column_result(read_coalition_bag(result.bag), 4) if result.bag and result.bag.exists() else {}
summary.pop('counts', None)
print(json.dumps({'exit_code': result.exit_code, 'message': result.message, 'summary': summary}))
'''


def run_split_column(tmp_path, discovery: str, discovery_timeout: float = 30.0) -> dict:
    with two_hosts('coal') as hosts:
        result = run_in(hosts.a, [sys.executable, '-c', COALITION_SPLIT, str(CONFIG), str(tmp_path / 'run'), hosts.b,
                                  discovery, str(discovery_timeout)], timeout=600, env=dict(os.environ))
    assert result.stdout.strip(), result.stderr[-3000:]
    return json.loads(result.stdout.strip().splitlines()[-1])


def test_coalition_agents_split_over_two_hosts_form_the_coalition(tmp_path):
    """The leader's agent host on A (with the bridge), the helpers' agent host on B."""
    outcome = run_split_column(tmp_path, 'SUBNET')
    assert outcome['exit_code'] == 0, outcome
    summary = outcome['summary']
    assert summary['state'] == 'committed', summary
    assert len(summary['members']) >= 2, summary  # the leader and at least one helper across the link
    session = yaml.safe_load((tmp_path / 'run' / 'session.json').read_text())
    assert session['nodes']['schema_agent_host_2']['command'][:3] == ['ip', 'netns', 'exec']


def test_coalition_split_with_local_only_discovery_fails(tmp_path):
    # Local-only discovery never reaches host B, however long the run waits for it: 8 s (as the demo's
    # local-only test above) instead of the default 30 s.
    outcome = run_split_column(tmp_path, 'LOCALHOST', discovery_timeout=8.0)
    assert outcome['exit_code'] == 4, outcome
    assert 'never discovered' in outcome['message']

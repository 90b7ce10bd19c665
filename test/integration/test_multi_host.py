"""Experiments split over two hosts (network namespaces joined by a veth pair).

The orchestrator runs on host A (as it would on the main machine) and starts some nodes on
host B through the experiment's `hosts`. With SUBNET discovery they meet; with the stock
local-only discovery the nodes on B are never discovered, and the run must fail (exit 4),
not end as a success.
"""
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

"""Runs under a Fast DDS discovery server: the session starts the server and every process is a
super client, so the orchestrator sees the graph, the recorder finds every topic and the coalition
agents' presence check sees their teammates.

Each run is its own process (as `scripts/orchestrate` runs it): once a process has been a
discovery-server client, Fast DDS participants it creates later discover nothing, so the test
process itself must stay out of it.
"""
import json
import os
import socket
import subprocess
import sys
from pathlib import Path

import yaml

from collab_tools.core.bag_analysis import summarize_bag

WORKSPACE = Path(__file__).resolve().parents[2]


def free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        probe.bind(('127.0.0.1', 0))
        return probe.getsockname()[1]


def test_demo_under_a_discovery_server_records_every_topic(config_dir, tmp_path):
    experiment = yaml.safe_load((config_dir / 'experiments' / 'demo_mobile.yaml').read_text())
    experiment['discovery'] = {'server': f'127.0.0.1:{free_udp_port()}', 'start_server': True}
    path = tmp_path / 'experiment.yaml'
    path.write_text(yaml.safe_dump(experiment, sort_keys=False))
    run_dir = tmp_path / 'run'
    result = subprocess.run([sys.executable, str(WORKSPACE / 'scripts' / 'orchestrate'), str(path),
                             '--run-dir', str(run_dir)], capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    topics = {t.topic: t.count for t in summarize_bag(next((run_dir / 'bags').iterdir())).topics}
    for topic in ('/clock', '/ground_truth/bodies', '/robot_1/cmd_vel', '/scripted_driver/done'):
        assert topics.get(topic, 0) > 0, f'{topic} not recorded under the discovery server: {sorted(topics)}'
    session = json.loads((run_dir / 'session.json').read_text())
    assert 'discovery server' in session['discovery']
    assert (run_dir / 'logs' / 'discovery_server_0.log').read_text().count('Server is running') == 1


COLUMN_UNDER_SERVER = '''
import json, sys
from pathlib import Path
from coalition_agents.core.sim_scenarios import COLUMN_TYPES, column_placements
from coalition_agents.experiments.coalition_bag import read_coalition_bag
from coalition_agents.experiments.column import COLUMN_CONFIG, column_result, load_column_config
from coalition_agents.experiments.sessions import AgentSetup, run_session
config, run_dir, server = Path(sys.argv[1]), Path(sys.argv[2]), sys.argv[3]
column = load_column_config(config / 'coalitions' / COLUMN_CONFIG)
placements = column_placements(3, column.spacing_m)
setup = AgentSetup(leaders=(placements[-1].robot,), search_time_s=3.0, link_preset=column.link_preset,
                   timeout_s=120.0, host_processes=2, discovery={'server': server, 'start_server': True})
result = run_session(run_dir, config, 'column_under_server', placements, COLUMN_TYPES, column.sensors, setup)
summary = column_result(read_coalition_bag(result.bag), 3) if result.bag and result.bag.exists() else {}
summary.pop('counts', None)
print(json.dumps({'exit_code': result.exit_code, 'message': result.message, 'summary': summary}))
'''


def test_coalition_agents_see_their_teammates_under_a_discovery_server(config_dir, tmp_path):
    """The presence check (a teammate listens when the node publishing its status subscribes to its
    inbox) needs the whole graph: as super clients the agents see it, and the column forms."""
    result = subprocess.run([sys.executable, '-c', COLUMN_UNDER_SERVER, str(config_dir), str(tmp_path / 'run'),
                             f'127.0.0.1:{free_udp_port()}'], capture_output=True, text=True, timeout=300)
    assert result.stdout.strip(), result.stderr[-3000:]
    outcome = json.loads(result.stdout.strip().splitlines()[-1])
    assert outcome['exit_code'] == 0, outcome
    assert outcome['summary']['state'] == 'committed' and outcome['summary']['includes_all_robots'], outcome

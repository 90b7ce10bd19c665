"""A run under a Fast DDS discovery server: the session starts the server, every process is a
super client, so the orchestrator sees the graph and the recorder finds every topic."""
import socket

import yaml

from collab_tools.core.bag_analysis import summarize_bag
from collab_tools.orchestration.experiment import run_experiment


def free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        probe.bind(('127.0.0.1', 0))
        return probe.getsockname()[1]


def test_demo_under_a_discovery_server_records_every_topic(config_dir, tmp_path):
    experiment = yaml.safe_load((config_dir / 'experiments' / 'demo_mobile.yaml').read_text())
    experiment['discovery'] = {'server': f'127.0.0.1:{free_udp_port()}', 'start_server': True}
    path = tmp_path / 'experiment.yaml'
    path.write_text(yaml.safe_dump(experiment, sort_keys=False))
    result = run_experiment(path, config_dir, run_dir=tmp_path / 'run', log=None)
    assert result.exit_code == 0, result.message
    topics = {t.topic: t.count for t in summarize_bag(result.bag).topics}
    for topic in ('/clock', '/ground_truth/bodies', '/robot_1/cmd_vel', '/scripted_driver/done'):
        assert topics.get(topic, 0) > 0, f'{topic} not recorded under the discovery server: {sorted(topics)}'
    session = yaml.safe_load((tmp_path / 'run' / 'session.json').read_text())
    assert 'discovery server' in session['discovery']
    assert (tmp_path / 'run' / 'logs' / 'discovery_server_0.log').read_text().count('Server is running') == 1

"""Two complete simulations side by side in one ROS domain, each under its own namespace.

Each is the demo experiment (bridge, scripted driver, recorder) run by its own orchestrator
with `namespace:` set: its nodes live below it and /clock, /tf, /tf_static are remapped into
it. Simulation A drives its robots; B's plan keeps them still. If either heard the other's
commands or clock, B's robots would move or A's would not follow its own plan.
"""
import math
import os
import subprocess
import sys
from pathlib import Path

import yaml

from collab_tools.core.bag_analysis import read_messages, summarize_bag
from collab_tools.orchestration.domain import DomainUnavailableError, FIRST_DOMAIN_ID, LAST_DOMAIN_ID, \
    acquire_domain

WORKSPACE = Path(__file__).resolve().parents[2]
CONFIG = WORKSPACE / 'config'


def shared_domain():
    for domain_id in range(LAST_DOMAIN_ID, FIRST_DOMAIN_ID, -1):
        try:
            return acquire_domain(domain_id, shared=True)
        except DomainUnavailableError:
            continue
    raise RuntimeError('no ROS domain free to share')


def experiment_file(tmp_path: Path, namespace: str, domain_id: int, plan: Path) -> Path:
    experiment = yaml.safe_load((CONFIG / 'experiments' / 'demo_mobile.yaml').read_text())
    experiment.update(namespace=namespace, domain_id=domain_id, name=f'demo{namespace.replace("/", "_")}')
    for node in experiment['nodes']:
        if node['executable'] == 'scripted_driver':
            node['parameters'] = [{'plan_file': str(plan)}]
    path = tmp_path / f'{namespace.strip("/")}.yaml'
    path.write_text(yaml.safe_dump(experiment, sort_keys=False))
    return path


def robot_travel(bag: Path, topic: str) -> dict[str, float]:
    first = last = None
    for _, _, msg in read_messages(bag, [topic]):
        poses = {b.name: (b.pose.position.x, b.pose.position.y) for b in msg.bodies if b.kind == 'mobile_robot'}
        first = first or poses
        last = poses
    return {name: math.dist(first[name], last[name]) for name in first}


def test_two_namespaced_simulations_share_a_domain_without_hearing_each_other(tmp_path):
    plan = yaml.safe_load((CONFIG / 'plans' / 'demo_plan.yaml').read_text())
    still = {'robots': {robot: [{'linear': 0.0, 'angular': 0.0, 'duration': sum(s['duration'] for s in steps)}]
                        for robot, steps in plan['robots'].items()}}
    still_plan = tmp_path / 'still_plan.yaml'
    still_plan.write_text(yaml.safe_dump(still))
    lease = shared_domain()
    try:
        runs = {}
        for namespace, plan_file in (('/sim_a', CONFIG / 'plans' / 'demo_plan.yaml'), ('/sim_b', still_plan)):
            path = experiment_file(tmp_path, namespace, lease.domain_id, plan_file)
            runs[namespace] = subprocess.Popen(
                [sys.executable, str(WORKSPACE / 'scripts' / 'orchestrate'), str(path),
                 '--run-dir', str(tmp_path / namespace.strip('/'))],
                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=dict(os.environ))
        outputs = {namespace: process.communicate(timeout=300)[0] for namespace, process in runs.items()}
    finally:
        lease.release()
    for namespace, process in runs.items():
        assert process.returncode == 0, f'{namespace}:\n{outputs[namespace][-3000:]}'

    bags = {ns: next((tmp_path / ns.strip('/') / 'bags').iterdir()) for ns in runs}
    for namespace, bag in bags.items():
        topics = {t.topic for t in summarize_bag(bag).topics}
        assert f'{namespace}/clock' in topics and f'{namespace}/robot_1/cmd_vel' in topics, topics
        strays = [t for t in topics if not t.startswith(namespace + '/')]
        assert not strays, f'{namespace} recorded topics of another simulation: {strays}'

    moved_a = robot_travel(bags['/sim_a'], '/sim_a/ground_truth/bodies')
    moved_b = robot_travel(bags['/sim_b'], '/sim_b/ground_truth/bodies')
    assert all(distance > 0.3 for distance in moved_a.values()), moved_a
    assert all(distance < 0.02 for distance in moved_b.values()), moved_b

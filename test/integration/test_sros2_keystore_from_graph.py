"""scripts/tools/sros2_keystore.py on an experiment: each node's permissions come from the ROS graph.

A small experiment (the bridge with two arms, a few seconds) is run unsecured by the tool; the keystore
must then hold the bridge's enclave with what it really does -- /clock published, the reset service
served, each arm's pick_and_place served as an action (folded from its services and topics) -- and
nothing it does not (a robot's cmd_vel it never subscribed), signed so that --check verifies it.
"""
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import yaml

from collab_tools.core.sros2_policy import parse_policy

WORKSPACE = Path(__file__).resolve().parents[2]


def test_keystore_from_an_experiments_graph(config_dir, tmp_path):
    experiment = tmp_path / 'arms.yaml'
    experiment.write_text(yaml.safe_dump({
        'name': 'arms_keystore', 'timeout': 30, 'until': {'seconds': 3.0},
        'nodes': [{'package': 'pybullet_bridge', 'executable': 'pybullet_bridge', 'use_sim_time': False,
                   'parameters': [{'scenario': str(config_dir / 'scenarios' / 'test_tabletop.yaml'),
                                   'publish_camera': False, 'real_time_factor': 1.0}]}]}))
    keystore = tmp_path / 'keystore'
    tool = [sys.executable, str(WORKSPACE / 'scripts' / 'tools' / 'sros2_keystore.py')]
    made = subprocess.run([*tool, str(experiment), '--keystore', str(keystore)], capture_output=True, text=True,
                          timeout=240)
    assert made.returncode == 0, made.stdout + made.stderr
    assert '2 enclaves' in made.stdout   # the bridge and the orchestrator (no recorder: nothing recorded)

    bridge = {a.enclave: a for a in parse_policy((keystore / 'policy.xml').read_text())}['/pybullet_bridge']
    assert {'/clock', '/tf', '/ground_truth/bodies', '/leader_arm/joint_states'} <= bridge.publish
    assert {'/pybullet_bridge/reset', '/pybullet_bridge/get_parameters'} <= bridge.reply
    assert bridge.execute == {'/leader_arm/pick_and_place', '/follower_arm/pick_and_place'}
    assert not any('_action' in name for name in bridge.reply | bridge.publish)
    assert not any(name.endswith('cmd_vel') for name in bridge.subscribe)

    permissions = ET.parse(keystore / 'enclaves' / 'pybullet_bridge' / 'permissions.xml').getroot()
    published = {t.text for t in permissions.find('permissions/grant/allow_rule').findall('publish/topics/topic')}
    assert {'rt/clock', 'rr/pybullet_bridge/resetReply', 'rt/leader_arm/pick_and_place/_action/feedback'} <= published
    checked = subprocess.run([*tool, '--check', str(keystore)], capture_output=True, text=True, timeout=60)
    assert checked.returncode == 0, checked.stderr
    assert checked.stdout.split() == ['/orchestrator', '/pybullet_bridge']

"""SROS2 keystores (collab_tools.sros2_keystore, core.sros2_policy) and a secured session's settings.

The keystore must be what ``ros2 security create_keystore/create_enclave`` makes: the same layout and
links, certificates chained to the CA with the enclave as CN, governance and permissions valid XML in
the OMG DDS-Security formats, S/MIME signatures that openssl verifies (and that fail once a document
is changed). On the PyPI wheels a secured session refuses Enforce in one line and runs Permissive
unsecured after saying so.
"""
import os
import shutil
import subprocess
import xml.etree.ElementTree as ET
from functools import partial

import pytest

from collab_tools.core.sros2_policy import (NodeAccess, PolicyError, access_from_graph, dds_topics,
                                            governance_xml, parse_policy, permissions_xml, policy_xml)
from collab_tools.orchestration import security as security_module
from collab_tools.orchestration import session as session_module
from collab_tools.orchestration.node_process import NodeSpec
from collab_tools.orchestration.security import (Security, SecurityConfigError, SecurityUnavailable,
                                                 middleware_can_secure)
from collab_tools.orchestration.session import Session
from collab_tools.sros2_keystore import Keystore, KeystoreError, verify

needs_openssl = pytest.mark.skipif(shutil.which('openssl') is None, reason='no openssl command')

PLAYER = NodeAccess('/burger1/role_player', publish={'/burger1/cmd_vel', '/roles/channel', '/rosout'},
                    subscribe={'/roles/channel', '/top_camera/image_raw', '/clock'},
                    reply={'/burger1/role_player/get_parameters'}, request={'/pybullet_bridge/reset'},
                    call={'/leader_arm/pick_and_place'})


# --- policies and DDS documents -------------------------------------------------------------------

def test_ros_names_map_to_dds_topics_as_sros2_does():
    publish, subscribe = dds_topics(PLAYER)
    assert {'rt/burger1/cmd_vel', 'rt/roles/channel', 'rq/pybullet_bridge/resetRequest',
            'rr/burger1/role_player/get_parametersReply', 'rq/leader_arm/pick_and_place/_action/send_goalRequest',
            'rq/leader_arm/pick_and_place/_action/cancel_goalRequest'} <= set(publish)
    assert {'rt/clock', 'rr/pybullet_bridge/resetReply', 'rq/burger1/role_player/get_parametersRequest',
            'rr/leader_arm/pick_and_place/_action/get_resultReply', 'rt/leader_arm/pick_and_place/_action/feedback',
            'rt/leader_arm/pick_and_place/_action/status'} <= set(subscribe)
    server = NodeAccess('/pybullet_bridge', execute={'/leader_arm/pick_and_place'})
    publish, subscribe = dds_topics(server)
    assert 'rt/leader_arm/pick_and_place/_action/feedback' in publish
    assert 'rq/leader_arm/pick_and_place/_action/send_goalRequest' in subscribe
    assert publish == sorted(publish) and 'rt/burger1/cmd_vel' not in publish


def test_graph_endpoints_fold_an_action_back_into_one_name():
    action = '/leader_arm/pick_and_place'
    served = [f'{action}/_action/{s}' for s in ('send_goal', 'cancel_goal', 'get_result')] + ['/pybullet_bridge/reset']
    access = access_from_graph('/pybullet_bridge', [f'{action}/_action/feedback', f'{action}/_action/status', '/clock'],
                               ['/robot_1/cmd_vel'], served, [])
    assert access.execute == {action} and access.reply == {'/pybullet_bridge/reset'}
    assert access.publish == {'/clock'} and access.subscribe == {'/robot_1/cmd_vel'}
    client = access_from_graph('/leader', [], [f'{action}/_action/status', '/guidance'],
                               [], [f'{action}/_action/{s}' for s in ('send_goal', 'cancel_goal', 'get_result')])
    assert client.call == {action} and client.request == set() and client.subscribe == {'/guidance'}


def test_permissions_are_the_omg_format_deny_by_default():
    root = ET.fromstring(permissions_xml(PLAYER, 7, '2026-01-01T00:00:00+00:00', '2036-01-01T00:00:00+00:00'))
    grant = root.find('permissions/grant')
    assert grant.get('name') == '/burger1/role_player'
    assert grant.findtext('subject_name') == 'CN=/burger1/role_player'
    assert grant.findtext('validity/not_before') == '2026-01-01T00:00:00+00:00'
    assert [child.tag for child in grant][-1] == 'default' and grant.findtext('default') == 'DENY'
    rules = grant.findall('allow_rule')
    assert all(rule.findtext('domains/id') == '7' for rule in rules)
    published = [t.text for t in rules[0].findall('publish/topics/topic')]
    assert 'rt/burger1/cmd_vel' in published and 'rt/top_camera/image_raw' not in published
    assert [t.text for t in rules[1].iter('topic')] == ['ros_discovery_info', 'ros_discovery_info']
    any_domain = ET.fromstring(permissions_xml(PLAYER, None, 'a', 'b')).find('permissions/grant/allow_rule/domains')
    assert (any_domain.findtext('id_range/min'), any_domain.findtext('id_range/max')) == ('0', '232')


def test_governance_protects_everything():
    rule = ET.fromstring(governance_xml(3)).find('domain_access_rules/domain_rule')
    assert rule.findtext('domains/id') == '3'
    assert rule.findtext('allow_unauthenticated_participants') == 'false'
    assert rule.findtext('rtps_protection_kind') == 'ENCRYPT'
    topic_rule = rule.find('topic_access_rules/topic_rule')
    assert topic_rule.findtext('topic_expression') == '*'
    assert topic_rule.findtext('enable_write_access_control') == 'true'


def test_policy_round_trip_and_sros2_relative_names():
    other = NodeAccess('/pybullet_bridge', publish={'/clock'}, execute={'/leader_arm/pick_and_place'})
    parsed = {a.enclave: a for a in parse_policy(policy_xml([PLAYER, other]))}
    assert parsed['/burger1/role_player'] == PLAYER and parsed['/pybullet_bridge'] == other
    written = ET.fromstring(policy_xml([PLAYER]))
    assert written.get('version') == '0.2.0'
    assert written.find('enclaves/enclave/profiles/profile').attrib == {'ns': '/burger1', 'node': 'role_player'}
    # As ros2 security generate_policy writes them: names relative to the profile's namespace.
    sros2_style = '''<policy version="0.2.0"><enclaves><enclave path="/talker"><profiles>
      <profile ns="/demo" node="talker"><topics publish="ALLOW"><topic>chatter</topic><topic>/rosout</topic></topics>
      <services reply="ALLOW"><service>~get_parameters</service></services></profile>
      </profiles></enclave></enclaves></policy>'''
    talker = parse_policy(sros2_style)[0]
    assert talker.publish == {'/demo/chatter', '/rosout'} and talker.reply == {'/demo/talker/get_parameters'}
    with pytest.raises(PolicyError, match='only ALLOW'):
        parse_policy(sros2_style.replace('publish="ALLOW"', 'publish="DENY"'))
    with pytest.raises(PolicyError, match='not XML'):
        parse_policy('<policy')


# --- the keystore on disk ---------------------------------------------------------------------------

def _openssl(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(['openssl', *args], capture_output=True, text=True)


@pytest.fixture(scope='module')
def keystore(tmp_path_factory):
    if shutil.which('openssl') is None:
        pytest.skip('no openssl command')
    store = Keystore(tmp_path_factory.mktemp('sros2') / 'keystore')
    store.write([PLAYER, NodeAccess('/pybullet_bridge', publish={'/clock'})], None)
    return store


@needs_openssl
def test_keystore_layout_is_sros2s(keystore):
    root = keystore.root
    for path in ('public/ca.cert.pem', 'private/ca.key.pem', 'enclaves/governance.xml', 'enclaves/governance.p7s',
                 'policy.xml'):
        assert (root / path).is_file(), path
    for role in ('identity_ca', 'permissions_ca'):
        assert os.readlink(root / 'public' / f'{role}.cert.pem') == 'ca.cert.pem'
        assert os.readlink(root / 'private' / f'{role}.key.pem') == 'ca.key.pem'
    enclave = root / 'enclaves' / 'burger1' / 'role_player'
    assert {p.name for p in enclave.iterdir()} == {'cert.pem', 'key.pem', 'permissions.xml', 'permissions.p7s',
                                                  'governance.p7s', 'identity_ca.cert.pem', 'permissions_ca.cert.pem'}
    assert os.readlink(enclave / 'governance.p7s') == '../../governance.p7s'
    assert (enclave / 'identity_ca.cert.pem').resolve() == (root / 'public' / 'ca.cert.pem').resolve()
    assert (enclave / 'key.pem').stat().st_mode & 0o077 == 0
    assert keystore.is_valid() and keystore.enclave_names() == ['/burger1/role_player', '/pybullet_bridge']


@needs_openssl
def test_enclave_certificate_is_its_name_issued_by_the_ca(keystore):
    cert = keystore.enclaves / 'burger1' / 'role_player' / 'cert.pem'
    subject = _openssl('x509', '-in', str(cert), '-noout', '-subject', '-issuer').stdout
    assert 'subject=CN = /burger1/role_player' in subject and 'issuer=CN = sros2CA' in subject
    assert _openssl('verify', '-CAfile', str(keystore.ca_cert), str(cert)).returncode == 0
    key_type = _openssl('pkey', '-in', str(cert.with_name('key.pem')), '-noout', '-text').stdout
    assert 'prime256v1' in key_type or 'P-256' in key_type


@needs_openssl
def test_signatures_verify_and_a_changed_document_does_not(keystore, tmp_path):
    enclave = keystore.enclaves / 'burger1' / 'role_player'
    signed = _openssl('smime', '-verify', '-in', str(enclave / 'permissions.p7s'), '-CAfile', str(keystore.ca_cert),
                      '-purpose', 'any')
    assert signed.returncode == 0, signed.stderr
    assert 'Content-Type: text/plain' in signed.stdout       # signed as text, as sros2 signs
    content = verify(enclave / 'permissions.p7s', keystore.ca_cert)
    assert '<grant name="/burger1/role_player">' in content
    ET.fromstring((enclave / 'permissions.xml').read_text())
    assert '<topic_expression>*</topic_expression>' in verify(keystore.enclaves / 'governance.p7s', keystore.ca_cert)
    forged = tmp_path / 'forged.p7s'
    forged.write_text((enclave / 'permissions.p7s').read_text().replace('rt/burger1/cmd_vel', 'rt/burger2/cmd_vel'))
    with pytest.raises(KeystoreError, match='smime failed'):
        verify(forged, keystore.ca_cert)


@needs_openssl
def test_rewriting_keeps_the_ca_and_keys_and_refuses_bad_enclave_names(keystore):
    ca, key = keystore.ca_cert.read_bytes(), (keystore.enclaves / 'pybullet_bridge' / 'key.pem').read_bytes()
    keystore.write([NodeAccess('/pybullet_bridge', publish={'/clock', '/tf'})], 0)
    assert keystore.ca_cert.read_bytes() == ca
    assert (keystore.enclaves / 'pybullet_bridge' / 'key.pem').read_bytes() == key
    assert 'rt/tf' in (keystore.enclaves / 'pybullet_bridge' / 'permissions.xml').read_text()
    for bad in ('relative', '/', '/a/../b', '/a b'):
        with pytest.raises(KeystoreError, match='enclave: must be'):
            keystore.add_enclave(NodeAccess(bad), None)


# --- a secured session ------------------------------------------------------------------------------

def test_security_settings_name_the_field(tmp_path):
    assert Security.parse(None) is None
    security = Security.parse({'keystore': str(tmp_path), 'strategy': 'Permissive'}, 'experiment.security')
    assert security.environment() == {'ROS_SECURITY_ENABLE': 'true', 'ROS_SECURITY_STRATEGY': 'Permissive',
                                      'ROS_SECURITY_KEYSTORE': str(tmp_path.resolve())}
    for data, field in (({'strategy': 'Enforce'}, 'experiment.security.keystore'),
                        ({'keystore': 'x', 'strategy': 'enforce'}, 'experiment.security.strategy'),
                        ({'keystore': 'x', 'enclave': '/a'}, 'experiment.security.enclave'), ('x', 'experiment.security')):
        with pytest.raises(SecurityConfigError, match=field.replace('.', r'\.')):
            Security.parse(data, 'experiment.security')


@needs_openssl
def test_secured_session_passes_keystore_and_enclave_to_each_node(keystore, tmp_path, monkeypatch):
    started = []

    class FakeProcess:
        def __init__(self, spec, command, env, log_path, label=None):
            started.append((command, env))
            self.spec, self.command, self.log_path, self.name = spec, command, log_path, label
            self.stopped_by, self.popen = 'interrupted', type('Popen', (), {'pid': 0})()

        def poll(self):
            return 0

        def outcome(self):
            return 'stopped cleanly'
    monkeypatch.setattr(session_module, 'NodeProcess', FakeProcess)
    monkeypatch.setattr(session_module, 'resolve_security',
                        partial(security_module.resolve, probe=lambda domain_id: (True, '')))
    monkeypatch.setenv('ROS_SECURITY_ENCLAVE_OVERRIDE', '/inherited')   # never leaks into a node
    security = Security(keystore.root, 'Enforce')
    with Session('t', run_dir=tmp_path, namespace='/', log=None, security=security) as session:
        session.start(NodeSpec('role_engine', 'role_player', name='role_player', namespace='/burger1'))
        with pytest.raises(SecurityConfigError, match='no enclave for /robot_9/role_player'):
            session.start(NodeSpec('role_engine', 'role_player', name='role_player', namespace='/robot_9'))
    command, env = started[0]
    assert command[command.index('--ros-args'):][-2:] == ['--enclave', '/burger1/role_player']
    assert env['ROS_SECURITY_ENABLE'] == 'true' and env['ROS_SECURITY_STRATEGY'] == 'Enforce'
    assert env['ROS_SECURITY_KEYSTORE'] == str(keystore.root) and 'ROS_SECURITY_ENCLAVE_OVERRIDE' not in env
    assert len(started) == 1   # the node without an enclave never started


@pytest.fixture(scope='module')
def middleware():
    return middleware_can_secure()


def test_enforce_where_the_middleware_cannot_is_one_clear_refusal(middleware, tmp_path):
    able, reason = middleware
    if able:
        pytest.skip('this middleware has DDS-Security (an apt install): nothing to refuse')
    assert 'DDS-Security' in reason and '\n' not in reason
    lines = []
    with pytest.raises(SecurityUnavailable) as refused:
        security_module.resolve(Security(tmp_path, 'Enforce'), 0, lines.append, probe=lambda _d: middleware)
    assert 'Enforce requested but the middleware cannot enforce it' in str(refused.value)
    assert 'nothing was started' in str(refused.value) and '\n' not in str(refused.value)
    assert security_module.resolve(Security(tmp_path, 'Permissive'), 0, lines.append,
                                   probe=lambda _d: middleware) is None
    assert len(lines) == 1 and 'UNSECURED' in lines[0]


def test_permissive_session_on_such_a_middleware_runs_unsecured(middleware, tmp_path, monkeypatch):
    if middleware[0]:
        pytest.skip('this middleware has DDS-Security (an apt install)')
    monkeypatch.setattr(session_module, 'resolve_security',
                        partial(security_module.resolve, probe=lambda domain_id: middleware))
    lines = []
    with Session('t', run_dir=tmp_path, log=lines.append, security=Security(tmp_path, 'Permissive')) as session:
        env = session.environment()
    assert session.security is None and 'ROS_SECURITY_ENABLE' not in env
    assert any('WARNING security: Permissive' in line and 'UNSECURED' in line for line in lines)


def test_an_inherited_security_setting_reaches_no_node_of_an_unsecured_session(tmp_path, monkeypatch):
    monkeypatch.setenv('ROS_SECURITY_ENABLE', 'true')
    monkeypatch.setenv('ROS_SECURITY_STRATEGY', 'Enforce')
    monkeypatch.setenv('ROS_SECURITY_KEYSTORE', str(tmp_path / 'nowhere'))
    with Session('t', run_dir=tmp_path, log=None) as session:
        env = session.environment()
        names = session.observer.node_names()   # the observer starts unsecured (no RCLError)
    assert not any(name.startswith('ROS_SECURITY') for name in env)
    assert isinstance(names, set) and os.environ['ROS_SECURITY_ENABLE'] == 'true'   # restored

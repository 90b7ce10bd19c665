"""SROS2 access policies as data: what each node may publish, subscribe, serve and call.

Three XML documents, in the formats ``ros2 security`` (sros2) reads and writes, so a keystore made
here and one made by ``ros2 security create_keystore/create_enclave/create_permission`` on an apt
install are interchangeable:

* the *policy* (sros2's ``policy.xml``: ``<policy version="0.2.0"><enclaves><enclave path>``
  ``<profiles><profile ns node>`` with ``topics``/``services``/``actions`` lists), the readable
  source of the permissions; :func:`policy_xml` writes it, :func:`parse_policy` reads one back
  (also one from ``ros2 security generate_policy``);
* the DDS *permissions* of one enclave (OMG DDS-Security ``omg_shared_ca_permissions``): ROS names
  mapped to DDS topics the way sros2's ``permissions.xsl`` does -- ``rt`` + topic, ``rq``/``rr`` +
  service + ``Request``/``Reply``, an action's three services and two topics -- allowed, the rest
  denied;
* the domain *governance*: authenticated participants only, discovery, liveliness and data
  encrypted, read and write access controlled on every topic (sros2's default).

Names are absolute ROS names (the graph's); the orchestration gives every node the enclave of its
fully qualified name.
"""
from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass, field

from .errors import ConfigurationError

__all__ = ['NodeAccess', 'access_from_graph', 'dds_topics', 'governance_xml', 'parse_policy', 'permissions_xml', 'policy_xml']

POLICY_VERSION = '0.2.0'
#: rmw implementations publishing the ROS graph on ``ros_discovery_info`` (every node needs it).
GRAPH_INFO_TOPIC = 'ros_discovery_info'
_ACTION_SERVICES = ('cancel_goal', 'get_result', 'send_goal')
_ACTION_TOPICS = ('feedback', 'status')
_OMG = 'http://www.omg.org/spec/DDS-SECURITY/20170901/'
_XSI = 'http://www.w3.org/2001/XMLSchema-instance'


class PolicyError(ConfigurationError):
    """A policy file that cannot be read; the message names the element."""


@dataclass
class NodeAccess:
    """What one node (its enclave) may do; every name absolute (``/burger1/cmd_vel``)."""

    enclave: str
    publish: set[str] = field(default_factory=set)
    subscribe: set[str] = field(default_factory=set)
    reply: set[str] = field(default_factory=set)       # services it serves
    request: set[str] = field(default_factory=set)     # services it calls
    execute: set[str] = field(default_factory=set)     # actions it serves
    call: set[str] = field(default_factory=set)        # actions it sends goals to

    KINDS = ('publish', 'subscribe', 'reply', 'request', 'execute', 'call')

    def merge(self, other: NodeAccess) -> None:
        for kind in self.KINDS:
            getattr(self, kind).update(getattr(other, kind))

    @property
    def node_namespace(self) -> tuple[str, str]:
        """(namespace, node name) of the enclave path ``/a/b/node`` -> (``/a/b``, ``node``)."""
        head, _, node = self.enclave.rpartition('/')
        return head or '/', node


def access_from_graph(enclave: str, publishers, subscribers, servers, clients) -> NodeAccess:
    """A node's access from the names of its endpoints as the ROS graph lists them (topics it
    publishes and subscribes, services it serves and calls); an action shows there as its three
    services and two topics (``<action>/_action/send_goal`` ...) and is folded back into one name."""
    access = NodeAccess(enclave, set(publishers), set(subscribers), set(servers), set(clients))
    suffix = '/_action/send_goal'
    for served, topics, actions in ((access.reply, access.publish, access.execute),
                                    (access.request, access.subscribe, access.call)):
        for action in [name[:-len(suffix)] for name in served if name.endswith(suffix)]:
            actions.add(action)
            served.difference_update(f'{action}/_action/{s}' for s in _ACTION_SERVICES)
            topics.difference_update(f'{action}/_action/{t}' for t in _ACTION_TOPICS)
    return access


def dds_topics(access: NodeAccess) -> tuple[list[str], list[str]]:
    """The DDS topics ``access`` allows (published, subscribed), sorted, as sros2 maps them."""
    publish = {f'rt{t}' for t in access.publish}
    subscribe = {f'rt{t}' for t in access.subscribe}
    for service in access.reply:
        publish.add(f'rr{service}Reply')
        subscribe.add(f'rq{service}Request')
    for service in access.request:
        publish.add(f'rq{service}Request')
        subscribe.add(f'rr{service}Reply')
    for action in access.execute:
        publish.update(f'rr{action}/_action/{s}Reply' for s in _ACTION_SERVICES)
        publish.update(f'rt{action}/_action/{t}' for t in _ACTION_TOPICS)
        subscribe.update(f'rq{action}/_action/{s}Request' for s in _ACTION_SERVICES)
    for action in access.call:
        publish.update(f'rq{action}/_action/{s}Request' for s in _ACTION_SERVICES)
        subscribe.update(f'rr{action}/_action/{s}Reply' for s in _ACTION_SERVICES)
        subscribe.update(f'rt{action}/_action/{t}' for t in _ACTION_TOPICS)
    return sorted(publish), sorted(subscribe)


def _pretty(root: ET.Element) -> str:
    ET.indent(root)
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding='unicode') + '\n'


#: ROS domain ids (ROS_DOMAIN_ID); ``None`` for a document below means all of them.
MAX_DOMAIN_ID = 232


def _domains(parent: ET.Element, domain_id: int | None) -> None:
    domains = ET.SubElement(parent, 'domains')
    if domain_id is None:   # an experiment on whatever free domain the orchestration picks
        id_range = ET.SubElement(domains, 'id_range')
        ET.SubElement(id_range, 'min').text = '0'
        ET.SubElement(id_range, 'max').text = str(MAX_DOMAIN_ID)
    else:
        ET.SubElement(domains, 'id').text = str(domain_id)


def permissions_xml(access: NodeAccess, domain_id: int | None, not_before: str, not_after: str) -> str:
    """The enclave's DDS permissions (validity: ISO 8601 times of its certificate)."""
    root = ET.Element('dds', {'xmlns:xsi': _XSI, 'xsi:noNamespaceSchemaLocation': _OMG + 'omg_shared_ca_permissions.xsd'})
    grant = ET.SubElement(ET.SubElement(root, 'permissions'), 'grant', name=access.enclave)
    ET.SubElement(grant, 'subject_name').text = f'CN={access.enclave}'
    validity = ET.SubElement(grant, 'validity')
    ET.SubElement(validity, 'not_before').text = not_before
    ET.SubElement(validity, 'not_after').text = not_after
    publish, subscribe = dds_topics(access)
    if publish or subscribe:
        rule = ET.SubElement(grant, 'allow_rule')
        _domains(rule, domain_id)
        for kind, topics in (('publish', publish), ('subscribe', subscribe)):
            if topics:
                listed = ET.SubElement(ET.SubElement(rule, kind), 'topics')
                for topic in topics:
                    ET.SubElement(listed, 'topic').text = topic
    graph = ET.SubElement(grant, 'allow_rule')   # the graph itself (rmw_fastrtps publishes it)
    _domains(graph, domain_id)
    for kind in ('publish', 'subscribe'):
        ET.SubElement(ET.SubElement(ET.SubElement(graph, kind), 'topics'), 'topic').text = GRAPH_INFO_TOPIC
    ET.SubElement(grant, 'default').text = 'DENY'
    return _pretty(root)


def governance_xml(domain_id: int | None) -> str:
    """The domain governance sros2 writes: authenticate, encrypt and access-control everything."""
    root = ET.Element('dds', {'xmlns:xsi': _XSI, 'xsi:noNamespaceSchemaLocation': _OMG + 'omg_shared_ca_governance.xsd'})
    rule = ET.SubElement(ET.SubElement(root, 'domain_access_rules'), 'domain_rule')
    _domains(rule, domain_id)
    for tag, text in (('allow_unauthenticated_participants', 'false'), ('enable_join_access_control', 'true'),
                      ('discovery_protection_kind', 'ENCRYPT'), ('liveliness_protection_kind', 'ENCRYPT'),
                      ('rtps_protection_kind', 'ENCRYPT')):
        ET.SubElement(rule, tag).text = text
    topic_rule = ET.SubElement(ET.SubElement(rule, 'topic_access_rules'), 'topic_rule')
    for tag, text in (('topic_expression', '*'), ('enable_discovery_protection', 'true'),
                      ('enable_liveliness_protection', 'true'), ('enable_read_access_control', 'true'),
                      ('enable_write_access_control', 'true'), ('metadata_protection_kind', 'ENCRYPT'),
                      ('data_protection_kind', 'ENCRYPT')):
        ET.SubElement(topic_rule, tag).text = text
    return _pretty(root)


_POLICY_LISTS = (('topics', 'topic', ('publish', 'subscribe')), ('services', 'service', ('reply', 'request')),
                 ('actions', 'action', ('execute', 'call')))


def policy_xml(accesses: list[NodeAccess]) -> str:
    """sros2's policy format: one enclave per node, one profile, absolute names."""
    root = ET.Element('policy', version=POLICY_VERSION)
    enclaves = ET.SubElement(root, 'enclaves')
    for access in sorted(accesses, key=lambda a: a.enclave):
        namespace, node = access.node_namespace
        profile = ET.SubElement(ET.SubElement(ET.SubElement(enclaves, 'enclave', path=access.enclave), 'profiles'),
                                'profile', ns=namespace, node=node)
        for group, item, kinds in _POLICY_LISTS:
            # One list per permission set: names allowed both ways share a list, as sros2 writes them.
            by_kinds: dict[tuple[str, ...], list[str]] = {}
            for name in sorted(set().union(*(getattr(access, k) for k in kinds))):
                granted = tuple(k for k in kinds if name in getattr(access, k))
                by_kinds.setdefault(granted, []).append(name)
            for granted, names in by_kinds.items():
                listed = ET.SubElement(profile, group, {k: 'ALLOW' for k in granted})
                for name in names:
                    ET.SubElement(listed, item).text = name
    return _pretty(root)


def parse_policy(text: str, source: str = 'policy') -> list[NodeAccess]:
    """The enclaves of an sros2 policy (ours or ``ros2 security generate_policy``'s).

    Relative names in a profile resolve against its ``ns`` (``~name`` against ``ns/node``); a
    profile's DENY lists are not supported here (refused, naming the element)."""
    try:
        root = ET.fromstring(text)
    except ET.ParseError as error:
        raise PolicyError(f'{source}: not XML ({error})') from None
    if root.tag != 'policy' or root.find('enclaves') is None:
        raise PolicyError(f'{source}: expected <policy><enclaves>... (sros2 policy format {POLICY_VERSION})')
    accesses = []
    for index, enclave in enumerate(root.iter('enclave')):
        path = enclave.get('path', '')
        if not path.startswith('/'):
            raise PolicyError(f'{source}: enclave[{index}].path: must be absolute (got {path[:80]!r})')
        access = NodeAccess(path)
        for profile in enclave.iter('profile'):
            namespace, node = profile.get('ns', '/').rstrip('/'), profile.get('node', '')
            for group, item, kinds in _POLICY_LISTS:
                for listed in profile.iter(group):
                    for kind in kinds:
                        rule = listed.get(kind)
                        if rule is None:
                            continue
                        if rule != 'ALLOW':
                            raise PolicyError(f'{source}: enclave {path}: {group} {kind}={rule!r}: '
                                              'only ALLOW lists are supported')
                        for element in listed.iter(item):
                            name = (element.text or '').strip()
                            if name.startswith('~'):   # ~/name and ~name: below the node's own name
                                name = f"{namespace}/{node}/{name[1:].lstrip('/')}"
                            elif not name.startswith('/'):
                                name = f'{namespace}/{name}'
                            getattr(access, kind).add(name)
        accesses.append(access)
    return accesses

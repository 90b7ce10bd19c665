"""Where a session's nodes run and how they find each other: discovery settings and hosts.

Discovery (one per session, every node and the orchestrator's own observer use it):

    discovery: {range: LOCALHOST}                       # default: this machine only (tests)
    discovery: {range: SUBNET}                          # multicast on the local subnet
    discovery: {range: LOCALHOST, static_peers: [192.168.1.12]}   # unicast to named peers
    discovery: {server: '10.0.0.1:11811'}              # a Fast DDS discovery server
    discovery: {server: '127.0.0.1:11811', start_server: true}   # ... that the session starts

With a discovery server every process is started as a *super client* (``ROS_SUPER_CLIENT``):
a plain client only learns the endpoints it matches, so the recorder (which subscribes to what
it discovers) and the coalition agents' presence check would see no topics.

Hosts (optional, per node): where a node's process runs.

    hosts:
      arm_b: {netns: sgcm_b}     # started here through `ip netns exec sgcm_b` (tests, one machine)
      robot2: remote             # started on robot2 by `scripts/orchestrate FILE --host robot2`

Nodes without a host run where the orchestrator runs. A remote host's nodes are not started
here, but they are awaited like the others: every node of the experiment must appear in the ROS
graph within ``discovery_timeout``, or the run fails (peers that were never discovered are a
discovery mistake, not a result).
"""
from __future__ import annotations

import re
from dataclasses import dataclass

from ..core.errors import ConfigurationError

RANGES = ('LOCALHOST', 'SUBNET', 'OFF', 'SYSTEM_DEFAULT')
_SERVER = re.compile(r'^[A-Za-z0-9_.\-]+(:\d{1,5})?$')
_NETNS = re.compile(r'^[A-Za-z0-9_.\-]{1,64}$')


class NetworkConfigError(ConfigurationError):
    """A discovery or host setting that cannot work; the message names the field."""


@dataclass(frozen=True)
class Discovery:
    range: str = 'LOCALHOST'
    static_peers: tuple[str, ...] = ()
    servers: tuple[str, ...] = ()
    start_server: bool = False

    @classmethod
    def parse(cls, data, path: str = 'discovery') -> 'Discovery':
        if data is None:
            return cls()
        if isinstance(data, str):
            data = {'range': data}
        if not isinstance(data, dict):
            raise NetworkConfigError(f'{path}: must be a mapping (range, static_peers, server)')
        unknown = sorted(set(data) - {'range', 'static_peers', 'server', 'start_server'})
        if unknown:
            raise NetworkConfigError(f'{path}.{unknown[0]}: unknown field '
                                     '(allowed: range, server, start_server, static_peers)')
        servers = data.get('server', ())
        servers = (servers,) if isinstance(servers, str) else tuple(servers or ())
        for server in servers:
            if not isinstance(server, str) or not _SERVER.match(server):
                raise NetworkConfigError(f'{path}.server: must be host[:port] (got {server!r})')
        default_range = 'SYSTEM_DEFAULT' if servers else 'LOCALHOST'
        range_ = str(data.get('range', default_range)).upper()
        if range_ not in RANGES:
            raise NetworkConfigError(f"{path}.range: must be one of {', '.join(RANGES)} (got {data.get('range')!r})")
        peers = data.get('static_peers', ())
        if isinstance(peers, str):
            peers = (peers,)
        if not isinstance(peers, (list, tuple)) or not all(isinstance(p, str) and _SERVER.match(p) for p in peers):
            raise NetworkConfigError(f'{path}.static_peers: must be a list of host names or addresses')
        start_server = data.get('start_server', False)
        if not isinstance(start_server, bool):
            raise NetworkConfigError(f'{path}.start_server: must be true or false')
        if start_server and not servers:
            raise NetworkConfigError(f'{path}.start_server: needs server: HOST:PORT (where to listen)')
        return cls(range_, tuple(peers), servers, start_server)

    def server_commands(self) -> list[list[str]]:
        """`fastdds discovery` command lines for the servers this session starts itself."""
        if not self.start_server:
            return []
        commands = []
        for index, server in enumerate(self.servers):
            host, _, port = server.partition(':')
            commands.append(['fastdds', 'discovery', '-i', str(index), '-l', host, '-p', port or '11811'])
        return commands

    def environment(self) -> dict[str, str]:
        """The ROS environment variables that select this discovery (None-valued: unset)."""
        env = {'ROS_AUTOMATIC_DISCOVERY_RANGE': self.range,
               'ROS_STATIC_PEERS': ';'.join(self.static_peers)}
        if self.servers:
            env['ROS_DISCOVERY_SERVER'] = ';'.join(self.servers)
            env['ROS_SUPER_CLIENT'] = 'TRUE'
        return env

    @property
    def unset(self) -> tuple[str, ...]:
        """Variables a process must not inherit (a discovery server set in the user's shell)."""
        return () if self.servers else ('ROS_DISCOVERY_SERVER', 'ROS_SUPER_CLIENT')

    def describe(self) -> str:
        if self.servers:
            return f"discovery server {', '.join(self.servers)} (super clients)"
        peers = f", static peers {', '.join(self.static_peers)}" if self.static_peers else ''
        return f'range {self.range}{peers}'


@dataclass(frozen=True)
class Host:
    """A machine (or, in tests, a network namespace) some of an experiment's nodes run on."""
    name: str
    netns: str | None = None
    remote: bool = False

    @classmethod
    def parse(cls, name: str, data, path: str) -> 'Host':
        if data == 'remote' or data == {'remote': True}:
            return cls(name, remote=True)
        if not isinstance(data, dict) or set(data) != {'netns'}:
            raise NetworkConfigError(f"{path}: must be {{netns: NAME}} or 'remote'")
        if not isinstance(data['netns'], str) or not _NETNS.match(data['netns']):
            raise NetworkConfigError(f"{path}.netns: not a network namespace name (got {data['netns']!r})")
        return cls(name, netns=data['netns'])

    def wrap(self, command: list[str]) -> list[str]:
        """The command that runs `command` on this host (netns: same files and environment)."""
        if self.netns:
            return ['ip', 'netns', 'exec', self.netns, *command]
        raise NetworkConfigError(f"host {self.name} is remote: start its nodes there with "
                                 f"scripts/orchestrate FILE --host {self.name}")


def parse_hosts(data, path: str = 'hosts') -> dict[str, Host]:
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise NetworkConfigError(f"{path}: must map host names to {{netns: NAME}} or 'remote'")
    return {str(name): Host.parse(str(name), spec, f'{path}.{name}') for name, spec in data.items()}

"""The live view of a session: the live_view node (Foxglove WebSocket server) and the visualiser.

``scripts/demo --live`` and ``scripts/experiment NAME --live`` call :func:`enable`, which puts the
address into the environment (``COLLAB_LIVE_VIEW=HOST:PORT``); every :class:`~.session.Session`
created afterwards in that process (the experiments' own sessions included, whatever runner
creates them) then starts the two nodes first, in its own ROS domain and namespace, and stops
them with the others. One session runs at a time, so each one's server takes the port in turn
(the Foxglove app reconnects by itself between sessions).
"""
from __future__ import annotations

import os
import socket
from dataclasses import dataclass

from ..core.errors import ConfigurationError
from ..core.live_view import DEFAULT_HOST, DEFAULT_PORT, connect_hint, host_problem
from .node_process import NodeSpec

ENVIRONMENT = 'COLLAB_LIVE_VIEW'


@dataclass(frozen=True)
class LiveView:
    host: str = DEFAULT_HOST
    port: int = DEFAULT_PORT

    def specs(self) -> list[NodeSpec]:
        """The two nodes; not ``required``: the run does not depend on a viewer (a failure still shows
        in session.json and fails the session, so a viewer that could not serve is never silent)."""
        return [NodeSpec('collab_tools', 'live_view', name='live_view', required=False,
                         parameters=[{'host': self.host, 'port': self.port}]),
                NodeSpec('collab_tools', 'visualiser', name='visualiser', required=False)]

    def hint(self) -> str:
        return connect_hint(self.host, self.port)


def parse_address(text: str, what: str = '--live') -> LiveView:
    """'HOST:PORT', 'PORT' or '' (the defaults) -> LiveView; ConfigurationError naming ``what``."""
    host, _, port = text.rpartition(':') if ':' in text else ('', '', text)
    host = host.strip('[]') or DEFAULT_HOST
    try:
        number = int(port) if port else DEFAULT_PORT
    except ValueError:
        number = -1
    if not 1 <= number <= 65535:
        raise ConfigurationError(f'{what}: port must be an integer in [1, 65535] (got {port!r})')
    problem = host_problem(host)
    if problem is not None:
        raise ConfigurationError(f'{what}: host {problem}')
    return LiveView(host, number)


def from_environment() -> LiveView | None:
    text = os.environ.get(ENVIRONMENT)
    return parse_address(text, ENVIRONMENT) if text is not None else None


def enable(address: str = '') -> LiveView:
    """Turn the live view on for every session of this process (and its children); the address must
    be free now (ConfigurationError otherwise: before any node starts)."""
    live = parse_address(address)
    family = socket.AF_INET6 if ':' in live.host else socket.AF_INET
    with socket.socket(family, socket.SOCK_STREAM) as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            probe.bind((live.host, live.port))
        except OSError as error:
            raise ConfigurationError(f'--live: cannot serve on {live.host}:{live.port} ({error.strerror}); '
                                     'another live view running? choose another with --live HOST:PORT') from None
    os.environ[ENVIRONMENT] = f'{live.host}:{live.port}'
    return live

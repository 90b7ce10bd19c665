"""Two simulated hosts for multi-host tests: network namespaces joined by a veth pair.

    with two_hosts('sgcm') as hosts:
        hosts.run_in_a(['scripts/orchestrate', 'exp.yaml'])   # the orchestrator on host A
        # an experiment's `hosts: {b: {netns: <hosts.b>}}` puts nodes on host B

The pair gets a private /24 that exists only inside the two namespaces (with a multicast route
for DDS discovery); nothing is sent anywhere else. The namespaces, the veth pair and every
process left inside them are removed on exit, also when the test fails.
"""
from __future__ import annotations

import os
import shutil
import signal
import subprocess
from contextlib import contextmanager
from dataclasses import dataclass

import pytest


@dataclass(frozen=True)
class Hosts:
    a: str
    b: str
    address_a: str
    address_b: str


def _ip(*arguments: str, check: bool = True) -> subprocess.CompletedProcess:
    return subprocess.run(['ip', *arguments], check=check, capture_output=True, text=True)


def require_netns() -> None:
    if os.geteuid() != 0 or shutil.which('ip') is None:
        pytest.skip('multi-host tests need root and iproute2 (ip netns); CI runs as root')


def _kill_all_in(namespace: str) -> None:
    pids = _ip('netns', 'pids', namespace, check=False).stdout.split()
    for pid in pids:
        try:
            os.kill(int(pid), signal.SIGKILL)
        except (ProcessLookupError, ValueError):
            pass


@contextmanager
def two_hosts(tag: str):
    require_netns()
    unique = f'{os.getpid() % 100000}'
    a, b = f'collab_{tag}_{unique}_a', f'collab_{tag}_{unique}_b'
    veth_a, veth_b = f'cv{unique}a', f'cv{unique}b'   # interface names: at most 15 characters
    octet = 16 + os.getpid() % 200
    address_a, address_b = f'10.213.{octet}.1', f'10.213.{octet}.2'
    created = []
    try:
        for namespace in (a, b):
            _ip('netns', 'add', namespace)
            created.append(namespace)
        _ip('link', 'add', veth_a, 'type', 'veth', 'peer', 'name', veth_b)
        for namespace, veth, address in ((a, veth_a, address_a), (b, veth_b, address_b)):
            _ip('link', 'set', veth, 'netns', namespace)
            _ip('-n', namespace, 'addr', 'add', f'{address}/24', 'dev', veth)
            _ip('-n', namespace, 'link', 'set', veth, 'up')
            _ip('-n', namespace, 'link', 'set', 'lo', 'up')
            # DDS discovery multicasts (239.255.0.1); the route keeps it on the pair.
            _ip('-n', namespace, 'route', 'add', '224.0.0.0/4', 'dev', veth)
        yield Hosts(a, b, address_a, address_b)
    finally:
        for namespace in created:
            _kill_all_in(namespace)
        for namespace in created:
            _ip('netns', 'del', namespace, check=False)


def run_in(namespace: str, command: list[str], timeout: float, **kwargs) -> subprocess.CompletedProcess:
    """Run `command` inside `namespace` (same files and environment), capturing its output."""
    return subprocess.run(['ip', 'netns', 'exec', namespace, *command], capture_output=True, text=True,
                          timeout=timeout, **kwargs)

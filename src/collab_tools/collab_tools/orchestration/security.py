"""SROS2 for a session, opt-in: every node gets its enclave, or the run says plainly why not.

    security: {keystore: /path/to/keystore, strategy: Enforce}    # experiment file, or
    scripts/orchestrate FILE --security-keystore DIR [--security-strategy Enforce|Permissive]

A secured session starts every node with ``ROS_SECURITY_ENABLE=true``, ``ROS_SECURITY_STRATEGY``,
``ROS_SECURITY_KEYSTORE`` and ``--ros-args --enclave <its fully qualified name>``
(``/burger1/role_player``); the orchestrator's own observer uses the enclave ``/orchestrator``.
The keystore comes from ``scripts/tools/sros2_keystore.py`` (or ``ros2 security`` on an apt
install); a node without an enclave in it is refused before anything starts (exit 2, naming it).

Before any node starts, a probe process creates one secured participant with a throwaway keystore:
the Fast DDS of the PyPI wheels is built without the DDS-Security plugins and refuses every
secured participant -- in Permissive as well, as soon as the enclave exists. Then ``Enforce``
stops the run with one line and :data:`EXIT_SECURITY_UNAVAILABLE`; ``Permissive`` says in one line
that the run is unsecured and starts the nodes without security (what rcl's Permissive does
for a missing enclave), never a traceback.
"""
from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

from ..core.errors import ConfigurationError

STRATEGIES = ('Enforce', 'Permissive')
#: What rcl reads; a session sets them only when it is secured (an inherited value never leaks in).
SECURITY_VARIABLES = ('ROS_SECURITY_ENABLE', 'ROS_SECURITY_STRATEGY', 'ROS_SECURITY_KEYSTORE',
                      'ROS_SECURITY_ENCLAVE_OVERRIDE')
ORCHESTRATOR_ENCLAVE = '/orchestrator'
#: Exit code of scripts/orchestrate when Enforce was asked for and the middleware has no DDS security.
EXIT_SECURITY_UNAVAILABLE = 6
_PROBE_ENCLAVE = '/security_probe'
_PROBE = ("import rclpy\nrclpy.init(args=['--ros-args', '--enclave', '" + _PROBE_ENCLAVE + "'])\n"
          "rclpy.create_node('security_probe').destroy_node()\nrclpy.shutdown()\n")
_NO_PLUGINS = "doesn't have the security libraries"


class SecurityConfigError(ConfigurationError):
    """A security setting that cannot work (exit 2); the message names the field."""


class SecurityUnavailable(RuntimeError):
    """Enforce was requested and the middleware cannot enforce (exit :data:`EXIT_SECURITY_UNAVAILABLE`)."""


@dataclass(frozen=True)
class Security:
    keystore: Path
    strategy: str = 'Enforce'

    @classmethod
    def parse(cls, data, path: str = 'security') -> Security | None:
        if data is None:
            return None
        if not isinstance(data, dict):
            raise SecurityConfigError(f'{path}: must be a mapping (keystore, strategy)')
        unknown = sorted(set(data) - {'keystore', 'strategy'})
        if unknown:
            raise SecurityConfigError(f'{path}.{unknown[0]}: unknown field (allowed: keystore, strategy)')
        keystore = data.get('keystore')
        if not isinstance(keystore, str) or not keystore:
            raise SecurityConfigError(f'{path}.keystore: missing required field (the keystore directory)')
        strategy = data.get('strategy', 'Enforce')
        if strategy not in STRATEGIES:
            raise SecurityConfigError(f"{path}.strategy: must be one of {', '.join(STRATEGIES)} (got {str(strategy)[:40]!r})")
        return cls(Path(keystore).expanduser().resolve(), strategy)

    def environment(self) -> dict[str, str]:
        return {'ROS_SECURITY_ENABLE': 'true', 'ROS_SECURITY_STRATEGY': self.strategy,
                'ROS_SECURITY_KEYSTORE': str(self.keystore)}

    def missing_enclaves(self, enclaves: list[str]) -> list[str]:
        """Those of ``enclaves`` the keystore has no key, certificate or signed permissions for."""
        files = ('key.pem', 'cert.pem', 'permissions.p7s', 'governance.p7s', 'identity_ca.cert.pem',
                 'permissions_ca.cert.pem')
        return [e for e in enclaves
                if not all(self.keystore.joinpath('enclaves', *e.strip('/').split('/'), f).is_file()
                           for f in files)]

    def check_keystore(self, enclaves: list[str]) -> None:
        """SecurityConfigError naming the first node without a usable enclave (before anything starts)."""
        root = self.keystore
        if not (root / 'enclaves' / 'governance.p7s').is_file():
            raise SecurityConfigError(f'security.keystore: {root} is not an SROS2 keystore (no enclaves/governance.p7s); '
                                      'create it with scripts/tools/sros2_keystore.py')
        missing = self.missing_enclaves(enclaves)
        if missing:
            raise SecurityConfigError(
                f"security.keystore: no enclave for {', '.join(missing[:5])}{' ...' if len(missing) > 5 else ''} "
                f'in {root} (add them: scripts/tools/sros2_keystore.py EXPERIMENT --keystore {root})')


def middleware_can_secure(domain_id: int = 0, python: str = sys.executable,
                          timeout: float = 60.0) -> tuple[bool, str]:
    """(True, '') if this rmw creates a secured participant; else (False, the reason in one line).

    Runs a probe process with a throwaway keystore holding one enclave (our orchestrator's process
    must not try: a failed secured init cannot be undone in it)."""
    from ..sros2_keystore import Keystore, KeystoreError
    from ..core.sros2_policy import NodeAccess

    with tempfile.TemporaryDirectory(prefix='sros2_probe_') as tmp:
        try:
            Keystore(Path(tmp)).write([NodeAccess(_PROBE_ENCLAVE, publish={'/rosout'})], None)
        except KeystoreError as error:
            return False, f'cannot create a probe keystore: {error}'
        env = dict(os.environ, ROS_SECURITY_ENABLE='true', ROS_SECURITY_STRATEGY='Enforce',
                   ROS_SECURITY_KEYSTORE=tmp,
                   ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST', ROS_DOMAIN_ID=str(domain_id))
        try:
            result = subprocess.run([python, '-c', _PROBE], env=env, capture_output=True, timeout=timeout)
        except subprocess.TimeoutExpired:
            return False, f'the security probe did not finish within {timeout:g} s'
    if result.returncode == 0:
        return True, ''
    error = result.stderr.decode(errors='replace')
    if _NO_PLUGINS in error:
        return False, ('this Fast DDS is built without the DDS-Security plugins (the PyPI wheels are; '
                       'an apt ROS 2 Jazzy install has them)')
    lines = [line.strip() for line in error.splitlines() if 'Error' in line or 'error' in line]
    return False, f"a secured participant could not be created: {(lines[-1] if lines else error.strip())[:300]}"


def resolve(security: Security | None, domain_id: int, log, probe=middleware_can_secure) -> Security | None:
    """The security the session runs with: ``security``, or None after a plain warning (Permissive on a
    middleware without DDS security); SecurityUnavailable for Enforce there."""
    if security is None:
        return None
    able, reason = probe(domain_id)
    if able:
        log(f'[session] security: {security.strategy}, keystore {security.keystore}')
        return security
    if security.strategy == 'Enforce':
        raise SecurityUnavailable(f'security: Enforce requested but the middleware cannot enforce it: {reason}; '
                                  'nothing was started')
    log(f'[session] WARNING security: Permissive requested but the middleware has no DDS security ({reason}): '
        'this run is UNSECURED, anyone on the domain can read and write every topic')
    return None

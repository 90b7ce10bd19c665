"""An SROS2 keystore written with the ``openssl`` command line, in the layout ``ros2 security`` uses.

    <keystore>/public/ca.cert.pem            the CA (prime256v1, self-signed, CN=sros2CA)
    <keystore>/public/{identity,permissions}_ca.cert.pem -> ca.cert.pem
    <keystore>/private/ca.key.pem            (and the two CA key links, as sros2 makes them)
    <keystore>/enclaves/governance.xml + governance.p7s   (S/MIME signed by the permissions CA)
    <keystore>/enclaves/<enclave path>/      key.pem, cert.pem (CN=<enclave path>), permissions.xml +
                                             permissions.p7s, and links to the two CA certs and governance.p7s
    <keystore>/policy.xml                    the policy the permissions came from (sros2's format)

``ROS_SECURITY_KEYSTORE=<keystore>`` with ``--ros-args --enclave <path>`` is what rcl reads; the
documents are those of :mod:`collab_tools.core.sros2_policy`. Why openssl and not sros2's Python
code: the PyPI wheels of this workspace have no sros2 (and no ``cryptography``); openssl is on every
machine that runs ROS. What exists is kept (the CA, an enclave's key), so adding an experiment's
enclaves to a keystore never invalidates the others; permissions are always rewritten.
"""
from __future__ import annotations

import os
import secrets
import shutil
import subprocess
import tempfile
from datetime import datetime, timezone
from pathlib import Path

from .core.errors import ConfigurationError
from .core.sros2_policy import NodeAccess, governance_xml, permissions_xml, policy_xml

CA_COMMON_NAME = 'sros2CA'
VALID_DAYS = 3650   # as sros2


class KeystoreError(ConfigurationError):
    """A keystore that cannot be written or checked (no openssl, a bad enclave name, a failed step)."""


def openssl() -> str:
    path = shutil.which('openssl')
    if path is None:
        raise KeystoreError('the openssl command is needed to create keys and sign files (apt install openssl)')
    return path


def _run(*args: str, stdin: bytes | None = None) -> str:
    result = subprocess.run([openssl(), *args], input=stdin, capture_output=True, timeout=60)
    if result.returncode != 0:
        raise KeystoreError(f"openssl {args[0]} failed: {result.stderr.decode(errors='replace').strip()[:400]}")
    return result.stdout.decode(errors='replace')


def _link(target: str, link: Path) -> None:
    if link.is_symlink() or link.exists():
        link.unlink()
    link.symlink_to(target)


def _new_key(path: Path) -> None:
    # DDS-Security 9.3.1: prime256v1; PKCS#8 PEM as sros2 writes it.
    _run('genpkey', '-algorithm', 'EC', '-pkeyopt', 'ec_paramgen_curve:P-256', '-out', str(path))
    path.chmod(0o600)


def _subject_config(common_name: str, ca: bool) -> str:
    # A config file, not -subj: an enclave's CN (/burger1/role_player) is full of slashes.
    constraints = 'critical,CA:true,pathlen:1' if ca else 'CA:false'
    return ('[req]\nprompt = no\ndistinguished_name = dn\nx509_extensions = ext\n'
            f'[dn]\nCN = {common_name}\n[ext]\nbasicConstraints = {constraints}\n')


def _certificate(key: Path, cert: Path, common_name: str, ca_cert: Path | None = None,
                 ca_key: Path | None = None) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        config = Path(tmp) / 'req.cnf'
        config.write_text(_subject_config(common_name, ca_cert is None))
        if ca_cert is None:   # self-signed CA
            _run('req', '-x509', '-new', '-key', str(key), '-config', str(config), '-sha256',
                 '-days', str(VALID_DAYS), '-set_serial', str(secrets.randbits(63)), '-out', str(cert))
            return
        request = Path(tmp) / 'req.pem'
        _run('req', '-new', '-key', str(key), '-config', str(config), '-out', str(request))
        _run('x509', '-req', '-in', str(request), '-CA', str(ca_cert), '-CAkey', str(ca_key), '-sha256',
             '-days', str(VALID_DAYS), '-set_serial', str(secrets.randbits(63)), '-extfile', str(config),
             '-extensions', 'ext', '-out', str(cert))


def sign(document: Path, signed: Path, ca_cert: Path, ca_key: Path) -> None:
    """S/MIME signature as sros2 makes it: clear text (text/plain), detached, SHA-256."""
    _run('smime', '-sign', '-text', '-md', 'sha256', '-in', str(document), '-signer', str(ca_cert),
         '-inkey', str(ca_key), '-out', str(signed))


def verify(signed: Path, ca_cert: Path) -> str:
    """The signed document's content if its signature verifies against ``ca_cert`` (KeystoreError if not)."""
    return _run('smime', '-verify', '-in', str(signed), '-CAfile', str(ca_cert), '-purpose', 'any')


def validity(cert: Path) -> tuple[str, str]:
    """(not before, not after) of a certificate, ISO 8601 UTC (what the permissions' validity says)."""
    dates = dict(line.split('=', 1) for line in _run('x509', '-in', str(cert), '-noout', '-startdate',
                                                     '-enddate').splitlines() if '=' in line)

    def iso(text: str) -> str:
        moment = datetime.strptime(' '.join(text.split()), '%b %d %H:%M:%S %Y %Z')
        return moment.replace(tzinfo=timezone.utc).isoformat()
    return iso(dates['notBefore']), iso(dates['notAfter'])


def check_enclave_path(path: str) -> str | None:
    """Problem text if ``path`` is not an absolute ROS namespace-like enclave name (None when it is)."""
    parts = path.split('/')
    if not path.startswith('/') or path == '/' or not all(
            p and (p[0].isalpha() or p[0] == '_') and all(c.isalnum() or c == '_' for c in p) for p in parts[1:]):
        return f'must be an absolute name of letters, digits and _ such as /burger1/role_player (got {path[:80]!r})'
    return None


class Keystore:
    """One keystore directory (created on first use)."""

    def __init__(self, root: Path):
        self.root = Path(root)
        self.public, self.private, self.enclaves = (self.root / d for d in ('public', 'private', 'enclaves'))

    @property
    def ca_cert(self) -> Path:
        return self.public / 'permissions_ca.cert.pem'

    @property
    def ca_key(self) -> Path:
        return self.private / 'permissions_ca.key.pem'

    def is_valid(self) -> bool:
        """What sros2 calls a valid keystore: both CAs' certs and keys and the signed governance."""
        return all(p.is_file() for p in (self.public / 'identity_ca.cert.pem', self.ca_cert,
                                         self.private / 'identity_ca.key.pem', self.ca_key,
                                         self.enclaves / 'governance.p7s'))

    def create(self, domain_id: int | None) -> None:
        for directory in (self.public, self.private, self.enclaves):
            directory.mkdir(parents=True, exist_ok=True)
        self.private.chmod(0o700)
        if not (self.public / 'ca.cert.pem').is_file() or not (self.private / 'ca.key.pem').is_file():
            _new_key(self.private / 'ca.key.pem')
            _certificate(self.private / 'ca.key.pem', self.public / 'ca.cert.pem', CA_COMMON_NAME)
        for role in ('identity_ca', 'permissions_ca'):
            _link('ca.cert.pem', self.public / f'{role}.cert.pem')
            _link('ca.key.pem', self.private / f'{role}.key.pem')
        governance = self.enclaves / 'governance.xml'
        governance.write_text(governance_xml(domain_id))
        sign(governance, self.enclaves / 'governance.p7s', self.ca_cert, self.ca_key)

    def enclave_dir(self, path: str) -> Path:
        problem = check_enclave_path(path)
        if problem:
            raise KeystoreError(f'enclave: {problem}')
        return self.enclaves.joinpath(*path.strip('/').split('/'))

    def add_enclave(self, access: NodeAccess, domain_id: int | None) -> Path:
        """Key, certificate and signed permissions of ``access.enclave`` (key and cert kept if present)."""
        if not self.is_valid():
            raise KeystoreError(f'{self.root}: not a keystore yet (create it first)')
        directory = self.enclave_dir(access.enclave)
        directory.mkdir(parents=True, exist_ok=True)
        for name, target in (('identity_ca.cert.pem', self.public / 'identity_ca.cert.pem'),
                             ('permissions_ca.cert.pem', self.ca_cert),
                             ('governance.p7s', self.enclaves / 'governance.p7s')):
            _link(os.path.relpath(target, directory), directory / name)
        key, cert = directory / 'key.pem', directory / 'cert.pem'
        if not key.is_file() or not cert.is_file():
            _new_key(key)
            _certificate(key, cert, access.enclave, self.public / 'identity_ca.cert.pem',
                         self.private / 'identity_ca.key.pem')
        permissions = directory / 'permissions.xml'
        permissions.write_text(permissions_xml(access, domain_id, *validity(cert)))
        sign(permissions, directory / 'permissions.p7s', self.ca_cert, self.ca_key)
        return directory

    def write(self, accesses: list[NodeAccess], domain_id: int | None) -> list[Path]:
        """The keystore (if new) with every enclave of ``accesses`` and their policy (policy.xml)."""
        if not self.is_valid():
            self.create(domain_id)
        (self.root / 'policy.xml').write_text(policy_xml(accesses))
        return [self.add_enclave(access, domain_id) for access in accesses]

    def enclave_names(self) -> list[str]:
        """Enclave paths in the keystore (every directory holding a key.pem), as ``list_enclaves`` shows."""
        return sorted('/' + key.parent.relative_to(self.enclaves).as_posix() for key in self.enclaves.rglob('key.pem'))

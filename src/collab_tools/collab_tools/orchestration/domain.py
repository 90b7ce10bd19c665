"""Allocation of an isolated ROS_DOMAIN_ID per orchestration session.

Sessions on one machine (parallel tests, an experiment beside a demo) must not hear
each other. Each session holds an exclusive lock file for its domain id for its whole
lifetime; the lock dies with the process, so a crashed session never leaks an id.
"""

import fcntl
import os
import random
import tempfile
from pathlib import Path

# ROS 2 documents 0..101 as safe on Linux (higher ids collide with ephemeral ports).
# 0 is the default every stray ROS process uses, so it is never handed out.
FIRST_DOMAIN_ID = 1
LAST_DOMAIN_ID = 101


class DomainUnavailableError(RuntimeError):
    pass


class DomainLease:
    """An exclusively held ROS domain id; release() or process exit frees it."""

    def __init__(self, domain_id: int, lock_file):
        self.domain_id = domain_id
        self._lock_file = lock_file

    def release(self) -> None:
        if self._lock_file is not None:
            fcntl.flock(self._lock_file, fcntl.LOCK_UN)
            self._lock_file.close()
            self._lock_file = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.release()


def _lock_dir() -> Path:
    path = Path(os.environ.get('COLLAB_DOMAIN_LOCK_DIR',
                               Path(tempfile.gettempdir()) / 'collab_ros_domains'))
    path.mkdir(parents=True, exist_ok=True)
    return path


def _try_lock(domain_id: int, shared: bool = False):
    lock_file = open(_lock_dir() / f'{domain_id}.lock', 'a+')
    try:
        fcntl.flock(lock_file, (fcntl.LOCK_SH if shared else fcntl.LOCK_EX) | fcntl.LOCK_NB)
    except BlockingIOError:
        lock_file.close()
        return None
    return lock_file


def acquire_domain(requested: int | None = None, seed: int | None = None,
                   shared: bool = False) -> DomainLease:
    """Lease `requested`, or the first free id from a random start when None.

    shared: several sessions that mean to meet in `requested` (two namespaced simulations, the
    parts of a multi-host experiment) hold it together; an exclusive lease excludes them all.
    """
    if requested is not None:
        if not FIRST_DOMAIN_ID <= requested <= LAST_DOMAIN_ID:
            raise DomainUnavailableError(
                f'domain_id: must be in [{FIRST_DOMAIN_ID}, {LAST_DOMAIN_ID}] (got {requested})')
        lock_file = _try_lock(requested, shared)
        if lock_file is None:
            raise DomainUnavailableError(
                f'domain_id: {requested} is in use by another session on this machine'
                + ('' if shared else ' (sessions that share a domain must all ask to share it)'))
        return DomainLease(requested, lock_file)

    ids = list(range(FIRST_DOMAIN_ID, LAST_DOMAIN_ID + 1))
    start = random.Random(seed).randrange(len(ids))
    for domain_id in ids[start:] + ids[:start]:
        lock_file = _try_lock(domain_id)
        if lock_file is not None:
            return DomainLease(domain_id, lock_file)
    raise DomainUnavailableError(
        f'every ROS domain id {FIRST_DOMAIN_ID}..{LAST_DOMAIN_ID} is held by another session')

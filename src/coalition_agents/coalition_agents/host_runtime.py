"""Process-level settings of an agent process: the garbage collector, and an optional profile.

Collector (:func:`tune_collector`, called once the agents are built): an agent process allocates
millions of short-lived objects per search (instances, offers, candidate lists) on top of a large,
long-lived heap (schema library, solution spaces, rclpy). With CPython's default thresholds
(700, 10, 10) the collector runs thousands of times per search and its full collections walk the
whole heap. :func:`tune_collector` moves everything built at start-up into the permanent generation
(:func:`gc.freeze`: never walked again) and collects the young generation every
:data:`YOUNG_THRESHOLD` allocations instead of 700. Nothing else changes: reference counting frees
almost everything at once, the collector only finds cycles, later. ``COALITION_HOST_GC=default``
in the environment keeps CPython's settings (the reference, for side-by-side runs).

Profile: ``COALITION_HOST_PROFILE=<directory>`` in the environment of a ``schema_agent_host``
process -- ``scripts/bench coalition`` and ``scripts/experiment`` pass their environment on to
the nodes -- makes it run its executor under :mod:`cProfile` and write, when it
stops, ``<directory>/<node>_<pid>.prof`` (read it with ``python -m pstats``) and
``<directory>/<node>_<pid>.json``: the wall time profiled and the garbage collector's pauses per
generation (count, total and longest, s), which a profile does not show. Without the variable
:func:`profiled` does nothing.
"""
from __future__ import annotations

import contextlib
import gc
import json
import os
import time
from pathlib import Path
from typing import Iterator

PROFILE_VARIABLE = 'COALITION_HOST_PROFILE'
GC_VARIABLE = 'COALITION_HOST_GC'
#: allocations (net) between two young-generation collections (CPython: 700)
YOUNG_THRESHOLD = 20000


def tune_collector() -> bool:
    """Freeze the start-up heap and collect the young generation less often (module docstring);
    ``COALITION_HOST_GC=default`` in the environment keeps CPython's settings (the reference, for
    side-by-side runs). Returns whether it tuned."""
    if os.environ.get(GC_VARIABLE, '') == 'default':
        return False
    gc.collect()
    gc.freeze()
    _, middle, old = gc.get_threshold()
    gc.set_threshold(YOUNG_THRESHOLD, middle, old)
    return True


class GcPauses:
    """The collector's pauses per generation, from :data:`gc.callbacks`."""

    def __init__(self) -> None:
        self.pauses: dict[int, list[float]] = {0: [], 1: [], 2: []}
        self._started = 0.0

    def __call__(self, phase: str, info: dict) -> None:
        if phase == 'start':
            self._started = time.perf_counter()
        else:
            self.pauses.setdefault(info.get('generation', 2), []).append(time.perf_counter() - self._started)

    def summary(self) -> dict:
        return {str(generation): {'count': len(values), 'total_s': round(sum(values), 4),
                                  'max_s': round(max(values, default=0.0), 4)}
                for generation, values in self.pauses.items()}


@contextlib.contextmanager
def profiled(name: str) -> Iterator[None]:
    """Profile the block if :data:`PROFILE_VARIABLE` names a directory (see the module docstring)."""
    directory = os.environ.get(PROFILE_VARIABLE, '')
    if not directory:
        yield
        return
    import cProfile
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    pauses = GcPauses()
    gc.callbacks.append(pauses)
    profile = cProfile.Profile()
    began = time.perf_counter()
    profile.enable()
    try:
        yield
    finally:
        profile.disable()
        gc.callbacks.remove(pauses)
        stem = out / f'{name}_{os.getpid()}'
        profile.dump_stats(str(stem.with_suffix('.prof')))
        stem.with_suffix('.json').write_text(json.dumps({'wall_s': round(time.perf_counter() - began, 3),
                                                         'gc': pauses.summary()}, indent=1))


__all__ = ['GC_VARIABLE', 'GcPauses', 'PROFILE_VARIABLE', 'YOUNG_THRESHOLD', 'profiled', 'tune_collector']

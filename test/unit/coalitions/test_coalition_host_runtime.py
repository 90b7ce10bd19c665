"""An agent process's runtime settings (coalition_agents.host_runtime): collector tuning, optional profile."""
from __future__ import annotations

import gc
import json

import pytest

from coalition_agents import host_runtime
from coalition_agents.host_runtime import GC_VARIABLE, PROFILE_VARIABLE, YOUNG_THRESHOLD, GcPauses, profiled, tune_collector


@pytest.fixture
def collector():
    """Restore the collector's thresholds and unfreeze after the test."""
    thresholds = gc.get_threshold()
    yield
    gc.unfreeze()
    gc.set_threshold(*thresholds)


def test_tune_collector_freezes_the_start_up_heap_and_raises_only_the_young_threshold(collector, monkeypatch):
    monkeypatch.delenv(GC_VARIABLE, raising=False)
    _, middle, old = gc.get_threshold()
    assert tune_collector()
    assert gc.get_threshold() == (YOUNG_THRESHOLD, middle, old)
    assert gc.get_freeze_count() > 0
    assert gc.isenabled()


def test_the_reference_keeps_cpythons_collector_settings(collector, monkeypatch):
    monkeypatch.setenv(GC_VARIABLE, 'default')
    before = gc.get_threshold()
    assert not tune_collector()
    assert gc.get_threshold() == before


def test_gc_pauses_are_summed_per_generation():
    pauses = GcPauses()
    gc.callbacks.append(pauses)
    try:
        gc.collect(0)
        gc.collect(2)
    finally:
        gc.callbacks.remove(pauses)
    summary = pauses.summary()
    assert summary['0']['count'] >= 1 and summary['2']['count'] >= 1
    assert summary['2']['max_s'] >= 0.0


def test_profiled_does_nothing_without_the_variable(monkeypatch, tmp_path):
    monkeypatch.delenv(PROFILE_VARIABLE, raising=False)
    with profiled('host'):
        sum(range(100))
    assert list(tmp_path.iterdir()) == []


def test_profiled_writes_the_profile_and_the_collector_pauses(monkeypatch, tmp_path):
    monkeypatch.setenv(PROFILE_VARIABLE, str(tmp_path / 'profiles'))
    with profiled('schema_agent_host'):
        gc.collect(0)
    written = sorted(path.suffix for path in (tmp_path / 'profiles').iterdir())
    assert written == ['.json', '.prof']
    report = json.loads(next((tmp_path / 'profiles').glob('*.json')).read_text())
    assert report['wall_s'] >= 0.0 and report['gc']['0']['count'] >= 1
    assert host_runtime.GcPauses not in map(type, gc.callbacks)  # removed again


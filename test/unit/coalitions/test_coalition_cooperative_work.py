"""CooperativeWork: the hosted agents' deferred work in bounded, round-robin steps."""
from __future__ import annotations

import time

import pytest

from coalition_agents.core.cooperative_work import CooperativeWork


class Wakes:
    def __init__(self):
        self.count = 0

    def __call__(self):
        self.count += 1


def counting_step(log, name, runs):
    """A step that logs its name and wants ``runs`` runs in all."""
    left = [runs]

    def step():
        log.append(name)
        left[0] -= 1
        return left[0] > 0
    return step


def test_steps_take_turns_and_a_repeated_request_runs_a_step_once():
    wakes, log = Wakes(), []
    work = CooperativeWork(wakes, budget_s=10.0)
    a, b = counting_step(log, 'a', 3), counting_step(log, 'b', 2)
    work.request(a)
    work.request(b)
    work.request(a)                       # already queued: no second entry
    assert wakes.count == 1               # one wake for the whole burst
    work.run()
    assert log == ['a', 'b', 'a', 'b', 'a']
    assert work.pending() == 0


def test_a_run_stops_after_its_budget_and_asks_to_be_woken_again():
    wakes, log = Wakes(), []
    work = CooperativeWork(wakes, budget_s=0.005)

    def slow():
        log.append('slow')
        time.sleep(0.01)
        return True
    fast = counting_step(log, 'fast', 1)
    work.request(slow)
    work.request(fast)
    work.run()
    assert log == ['slow']                # the budget was used by the first step
    assert wakes.count == 2               # and the runner asked for another turn
    work.run()
    assert log == ['slow', 'fast', 'slow']  # round robin: the waiting step went first


def test_a_failing_step_is_reported_and_dropped_without_stopping_the_others():
    wakes, log, errors = Wakes(), [], []
    work = CooperativeWork(wakes, budget_s=10.0, on_error=lambda step, exc: errors.append(str(exc)))

    def broken():
        raise RuntimeError('agent state is inconsistent')
    work.request(broken)
    work.request(counting_step(log, 'ok', 1))
    work.run()
    assert errors == ['agent state is inconsistent']
    assert log == ['ok']
    assert work.pending() == 0


def test_the_budget_must_be_positive():
    with pytest.raises(ValueError, match='budget_s'):
        CooperativeWork(Wakes(), budget_s=0.0)


def test_steps_requested_first_run_before_the_others_however_long_they_take():
    # The channel hands its agent the inbox first: the agent then reasons once with all of it.
    log, wakes = [], Wakes()
    work = CooperativeWork(wakes, budget_s=10.0)
    work.request(counting_step(log, 'reason', 2))
    work.request(counting_step(log, 'deliver', 3), first=True)
    assert work.pending() == 2
    work.run()
    assert log == ['deliver', 'deliver', 'deliver', 'reason', 'reason'] and work.pending() == 0

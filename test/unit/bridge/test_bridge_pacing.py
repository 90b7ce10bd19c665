"""Pacing of the bridge loop: ticks against the wall clock, rate schedules in simulated time."""
import pytest

from pybullet_bridge.core.pacing import (MAX_CATCH_UP_TICKS, RealTimeMeter, SimTimeSchedule, TickPacer,
                                         steps_per_tick)


def test_control_period_rounds_to_whole_physics_steps():
    assert steps_per_tick(0.01, 1.0 / 240.0) == 2
    assert steps_per_tick(0.001, 1.0 / 240.0) == 1     # at least one step
    assert steps_per_tick(0.1, 0.004) == 25


def test_ticks_follow_the_wall_clock_times_the_factor():
    pacer = TickPacer(control_period=0.01, real_time_factor=2.0)
    assert pacer.timer_period == pytest.approx(0.005)
    assert pacer.ticks_due(100.0, 0.0) == 0            # anchors: nothing due yet
    assert pacer.ticks_due(100.0151, 0.0) == 3         # 0.0302 s of sim time due
    assert pacer.ticks_due(100.0151, 0.03) == 0        # caught up


def test_a_machine_far_behind_catches_up_a_bounded_amount_then_reanchors():
    pacer = TickPacer(control_period=0.01, real_time_factor=1.0)
    pacer.ticks_due(0.0, 0.0)
    assert pacer.ticks_due(5.0, 0.0) == MAX_CATCH_UP_TICKS
    # Re-anchored at the next call: no backlog from the 5 s stall.
    assert pacer.ticks_due(5.0, 0.1) == 0
    assert pacer.ticks_due(5.02, 0.1) == 1


def test_factor_zero_runs_one_tick_per_call():
    pacer = TickPacer(control_period=0.01, real_time_factor=0.0)
    assert pacer.timer_period == 0.0
    assert [pacer.ticks_due(t, 0.0) for t in (0.0, 0.0, 10.0)] == [1, 1, 1]


def test_factor_zero_runs_a_batch_per_call_when_asked():
    pacer = TickPacer(control_period=0.01, real_time_factor=0.0, batch_ticks=6)
    assert [pacer.ticks_due(t, 0.0) for t in (0.0, 0.0, 7.0)] == [6, 6, 6]
    pacer.real_time_factor = 1.0                       # paced again: the batch no longer applies
    assert pacer.ticks_due(0.0, 0.0) == 0


def test_schedule_is_due_at_time_zero_then_every_period():
    schedule = SimTimeSchedule(rate=20.0)
    due = [t for t in (0.0, 0.01, 0.04, 0.05, 0.08, 0.1) if schedule.take_if_due(t)]
    assert due == [0.0, 0.05, 0.1]
    schedule.restart()
    assert schedule.take_if_due(0.0)


def test_higher_rate_applies_at_once_lower_after_the_scheduled_sample():
    schedule = SimTimeSchedule(rate=1.0)
    schedule.take_if_due(0.0)                  # next at 1.0
    schedule.set_rate(10.0, 0.2)
    assert schedule.next_time == pytest.approx(0.3)
    schedule.take_if_due(0.3)                  # next at 0.4
    schedule.set_rate(0.5, 0.3)
    assert schedule.next_time == pytest.approx(0.4)


def test_real_time_meter_measures_since_the_previous_call():
    meter = RealTimeMeter(10.0, 0.0)
    assert meter.measure(12.0, 1.0) == pytest.approx(0.5)
    assert meter.measure(13.0, 3.0) == pytest.approx(2.0)
    assert meter.measure(13.0, 3.0) == 0.0     # no wall time passed

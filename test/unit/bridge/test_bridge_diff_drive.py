"""Velocity and acceleration limiting of the differential-drive model."""
import math

import pytest

from pybullet_bridge.core.diff_drive import DiffDriveLimits, limit_velocity

LIMITS = DiffDriveLimits(max_linear_velocity=1.0, max_angular_velocity=2.0,
                         max_linear_acceleration=0.5, max_angular_acceleration=4.0)


@pytest.mark.parametrize('sign', [1.0, -1.0])
def test_target_is_clamped_to_velocity_limits(sign):
    # A long dt lets the acceleration limit reach any target; only the velocity clamp remains.
    assert limit_velocity((sign * 5.0, sign * 9.0), (0.0, 0.0), LIMITS, dt=100.0) == (sign * 1.0, sign * 2.0)


@pytest.mark.parametrize('sign', [1.0, -1.0])
def test_change_per_step_is_limited_by_acceleration(sign):
    linear, angular = limit_velocity((sign * 1.0, sign * 2.0), (0.0, 0.0), LIMITS, dt=0.1)
    assert linear == pytest.approx(sign * 0.05)
    assert angular == pytest.approx(sign * 0.4)


def test_braking_is_limited_too():
    assert limit_velocity((0.0, 0.0), (0.8, -1.0), LIMITS, dt=0.1) == pytest.approx((0.75, -0.6))


def test_reversing_passes_through_zero_at_the_acceleration_limit():
    velocity = (0.2, 0.0)
    for _ in range(10):
        velocity = limit_velocity((-1.0, 0.0), velocity, LIMITS, dt=0.1)
    assert velocity[0] == pytest.approx(0.2 - 10 * 0.05)


def test_target_within_reach_is_met_exactly():
    assert limit_velocity((0.52, 1.0), (0.5, 0.9), LIMITS, dt=0.1) == pytest.approx((0.52, 1.0))


def test_zero_dt_keeps_current_velocity():
    assert limit_velocity((1.0, 1.0), (0.3, -0.3), LIMITS, dt=0.0) == (0.3, -0.3)


def test_ramp_reaches_target_after_expected_time():
    velocity, dt, steps = (0.0, 0.0), 0.01, 0
    while velocity[0] < 0.8:
        velocity = limit_velocity((0.8, 0.0), velocity, LIMITS, dt)
        steps += 1
    assert steps * dt == pytest.approx(0.8 / LIMITS.max_linear_acceleration, abs=dt)


@pytest.mark.parametrize('target, current, dt', [
    ((math.nan, 0.0), (0.0, 0.0), 0.1), ((0.0, math.inf), (0.0, 0.0), 0.1),
    ((0.0, 0.0), (math.nan, 0.0), 0.1), ((0.0, 0.0), (0.0, 0.0), -0.1), ((0.0, 0.0), (0.0, 0.0), math.nan)])
def test_invalid_inputs_raise(target, current, dt):
    with pytest.raises(ValueError):
        limit_velocity(target, current, LIMITS, dt)


def test_limits_must_be_positive():
    with pytest.raises(ValueError, match='max_angular_acceleration'):
        DiffDriveLimits(1.0, 1.0, 1.0, 0.0)

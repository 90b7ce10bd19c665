"""Process-role interpolation between states (cubic Hermite = constant-velocity GP mean)."""
import numpy as np
import pytest

from role_engine.core.errors import RoleEngineError
from role_engine.core.initial_paths import polyline_trajectory, straight_line_trajectory
from role_engine.core.trajectory import densify, interpolate


def test_densify_passes_through_the_states_and_keeps_straight_lines_straight():
    states = straight_line_trajectory((0.0, 0.0), (2.0, 1.0), 4.0, 4)
    times, positions, velocities = densify(states, 4.0, 5)
    assert len(times) == 21 and times[-1] == 4.0
    assert positions[::5] == pytest.approx(states[:, :2])
    assert positions == pytest.approx(np.outer(times / 4.0, [2.0, 1.0]))
    assert velocities == pytest.approx(np.tile([0.5, 0.25], (21, 1)))


def test_interpolation_matches_states_and_its_own_derivatives():
    states = polyline_trajectory(np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]]), 3.0, 6)
    positions, velocities, _ = interpolate(states, 3.0, np.linspace(0, 3, 7))
    assert positions == pytest.approx(states[:, :2]) and velocities == pytest.approx(states[:, 2:])
    times = np.array([0.3, 1.1, 2.45])
    step = 1e-6
    p_plus, v_plus, _ = interpolate(states, 3.0, times + step)
    p_minus, v_minus, _ = interpolate(states, 3.0, times - step)
    _, velocity, acceleration = interpolate(states, 3.0, times)
    assert velocity == pytest.approx((p_plus - p_minus) / (2 * step), abs=1e-6)
    assert acceleration == pytest.approx((v_plus - v_minus) / (2 * step), abs=1e-4)


def test_before_and_after_the_role():
    states = straight_line_trajectory((0.0, 0.0), (1.0, 0.0), 2.0, 2)
    positions, velocities, accelerations = interpolate(states, 2.0, [-1.0, 5.0])
    assert positions == pytest.approx(np.array([[0.0, 0.0], [1.0, 0.0]]))
    assert velocities[1] == pytest.approx([0.0, 0.0]) and accelerations[1] == pytest.approx([0.0, 0.0])


def test_bad_arguments():
    states = straight_line_trajectory((0.0, 0.0), (1.0, 0.0), 2.0, 2)
    with pytest.raises(RoleEngineError, match='samples_per_interval'):
        densify(states, 2.0, 0)
    with pytest.raises(RoleEngineError, match='total_time'):
        interpolate(states, 0.0, [0.0])
    with pytest.raises(RoleEngineError, match='trajectory'):
        interpolate(states[:1], 1.0, [0.0])

"""Problem detection of the role engine (Algorithm 1): silent, stuck, off role, recovered."""
import numpy as np
import pytest

from role_engine.core.conflict import SharedRole
from role_engine.core.initial_paths import straight_line_trajectory
from role_engine.core.problems import Problem, ProblemSettings, ProblemWatch

SETTINGS = ProblemSettings(silence_timeout=4.0, stuck_distance=0.1, stuck_time=5.0, off_role_distance=0.5,
                           off_role_grace=3.0)
START = 10.0


def role(name='r', start=(0.0, 0.0), goal=(4.0, 0.0), total_time=20.0, start_time=START):
    """0.2 m/s along +x from ``start_time``."""
    return SharedRole(name, straight_line_trajectory(start, goal, total_time, 20), total_time, 0.1, start_time)


def watch_one(the_role=None):
    watch = ProblemWatch(SETTINGS)
    watch.expect({'r': the_role or role()})
    return watch


def feed(watch, times, position_at, robot='r', heard=True, arrived=False):
    """Heartbeat every second and a camera observation every 0.25 s; returns the problems at each second."""
    found = {}
    for t in np.arange(times[0], times[1] + 1e-9, 0.25):
        watch.observed(robot, t, position_at(t))
        if heard and abs(t - round(t)) < 1e-9:
            watch.heard(robot, t, arrived=arrived)
            found[round(t)] = watch.problems(t)
    return found


def on_role(the_role):
    return lambda t: the_role.positions([t])[0]


def test_a_robot_following_its_role_has_no_problem():
    the_role = role()
    watch = watch_one(the_role)
    found = feed(watch, (0.0, 35.0), on_role(the_role))
    assert all(problems == [] for problems in found.values())


def test_a_robot_that_stops_moving_is_stuck_after_stuck_time():
    the_role = role()
    watch = watch_one(the_role)
    stop = lambda t: the_role.positions([min(t, 14.0)])[0]   # noqa: E731  blocked at t = 14 s
    found = feed(watch, (0.0, 25.0), stop)
    first = min(t for t, problems in found.items() if problems)
    assert 19 <= first <= 20                                  # 14 s + stuck_time 5 s
    (problem,) = found[20]
    assert problem.kind == 'stuck' and problem.robot == 'r' and 'is stuck' in str(problem)


def test_a_stuck_robot_that_moves_again_has_recovered():
    the_role = role()
    watch = watch_one(the_role)
    found = feed(watch, (0.0, 20.0), lambda t: the_role.positions([min(t, 14.0)])[0])
    assert found[20][0].kind == 'stuck'
    # Freed at t = 21 s, its player re-plans from where it is (as role players do) and it moves on.
    resumed = role(start=tuple(the_role.positions([14.0])[0]), start_time=21.0, total_time=13.0)
    watch.heard('r', 21.0, role=resumed)
    found = feed(watch, (21.0, 30.0), on_role(resumed))
    assert found[21][0].kind == 'stuck'                       # not moved yet
    assert found[24] == [] and found[30] == []                # more than stuck_distance within stuck_time


def test_not_fooled_by_a_robot_that_has_not_started_or_has_arrived_or_waits_on_purpose():
    the_role = role()
    watch = watch_one(the_role)
    # Before its start (t < 10 s) and just after, standing at the start is fine.
    found = feed(watch, (0.0, 14.0), lambda t: (0.0, 0.0))
    assert all(problems == [] for problems in found.values())
    # A robot that reported arrival is never stuck or off role, wherever the camera sees it.
    arrived = watch_one(the_role)
    found = feed(arrived, (0.0, 40.0), lambda t: (2.0, 1.0), arrived=True)
    assert all(problems == [] for problems in found.values())
    # A role that waits 10 s at (1, 0) before moving on: standing there is not being stuck.
    waiting = SharedRole('r', np.array([[1.0, 0.0, 0.0, 0.0]] * 11 + [[1.0 + 0.2 * k, 0.0, 0.2, 0.0]
                                                                     for k in range(1, 11)]), 20.0, 0.1, START)
    watch = watch_one(waiting)
    found = feed(watch, (0.0, 18.0), lambda t: (1.0, 0.0))
    assert all(problems == [] for problems in found.values())


def test_a_robot_far_off_its_role_for_longer_than_the_grace_time():
    the_role = role()
    watch = watch_one(the_role)
    # Pushed 0.8 m sideways from t = 15 s on, but still moving along.
    pushed = lambda t: the_role.positions([t])[0] + ([0.0, 0.8] if t >= 15.0 else [0.0, 0.0])   # noqa: E731
    found = feed(watch, (0.0, 22.0), pushed)
    assert found[18] == []                                    # within the grace time
    (problem,) = found[19]
    assert problem.kind == 'off_role' and '0.80 m' in problem.detail


def test_off_role_briefly_is_forgiven_and_the_timer_restarts():
    the_role = role()
    watch = watch_one(the_role)
    blip = lambda t: the_role.positions([t])[0] + ([0.0, 0.8] if 15.0 <= t < 17.0 or t >= 20.0 else [0, 0])  # noqa: E731
    found = feed(watch, (0.0, 24.0), blip)
    assert all(found[t] == [] for t in range(0, 24))           # 2 s off, back, then off again from 20 s
    assert found[24][0].kind == 'off_role'


def test_a_newer_role_redefines_where_the_robot_should_be():
    the_role = role()
    watch = watch_one(the_role)
    detour = role(start=(0.0, 0.8), goal=(4.0, 0.8))
    feed(watch, (0.0, 14.0), on_role(the_role))
    watch.heard('r', 14.0, role=detour)
    found = feed(watch, (14.0, 22.0), on_role(detour))
    assert all(problems == [] for problems in found.values())


def test_silence_counts_from_the_role_start_and_from_the_last_heartbeat():
    the_role = role()
    watch = watch_one(the_role)
    assert watch.problems(START + 3.9) == []
    assert [p.kind for p in watch.problems(START + 4.1)] == ['silent']
    watch.heard('r', START + 5.0)
    assert watch.problems(START + 8.5) == []
    (problem,) = watch.problems(START + 9.5)
    assert problem == Problem('r', 'silent', problem.detail) and 'went silent' in str(problem)
    watch.heard('stranger', START + 9.5)                       # not of this round: ignored
    assert watch.robots == ['r']


def test_a_new_round_forgets_the_old_robots():
    watch = watch_one()
    watch.expect({'a': role('a'), 'b': role('b', start=(0.0, 1.0), goal=(4.0, 1.0))})
    assert watch.robots == ['a', 'b'] and watch.problems(START) == []


@pytest.mark.parametrize('data, message', [
    ({'stuck_distance': 0}, 'problem_detection.stuck_distance'),
    ({'stuck_time': -1.0}, 'problem_detection.stuck_time'),
    ({'off_role_distance': 'far'}, 'problem_detection.off_role_distance'),
    ({'off_role_grace': -0.5}, 'problem_detection.off_role_grace'),
    ({'timeout': 1.0}, 'problem_detection.timeout: unknown field'),
])
def test_bad_settings_name_the_field(data, message):
    with pytest.raises(ValueError, match=message):
        ProblemSettings.from_mapping(data)


def test_settings_defaults_and_silence_timeout():
    settings = ProblemSettings.from_mapping(None, silence_timeout=2.5)
    assert settings.silence_timeout == 2.5 and settings.stuck_distance == ProblemSettings.stuck_distance
    with pytest.raises(ValueError, match='problem_detection.silence_timeout'):
        ProblemSettings(silence_timeout=float('nan'))

"""core.throttle.RateThrottle: the compressed camera stream's rate limit in simulated time."""
import pytest

from pybullet_bridge.core.throttle import RateThrottle


def passed(throttle, times):
    out = []
    for t in times:
        if throttle.due(t):
            throttle.take(t)
            out.append(round(t, 6))
    return out


FRAMES_5HZ = [i * 0.2 for i in range(21)]   # a 5 Hz camera's frame times, 0 .. 4 s


def test_rate_zero_passes_every_frame():
    assert passed(RateThrottle(0.0), FRAMES_5HZ) == [round(t, 6) for t in FRAMES_5HZ]


def test_average_rate_is_kept_when_frames_do_not_divide_the_period():
    got = passed(RateThrottle(2.0), FRAMES_5HZ)
    # 2 Hz from a 5 Hz camera: slots every 0.5 s, each served by the first frame at or after it.
    assert got == [0.0, 0.6, 1.0, 1.6, 2.0, 2.6, 3.0, 3.6, 4.0]


@pytest.mark.parametrize('rate, expected', [(1.0, 5), (2.5, 11), (5.0, 21), (100.0, 21)])
def test_counts_over_four_seconds(rate, expected):
    assert len(passed(RateThrottle(rate), FRAMES_5HZ)) == expected


def test_after_a_gap_it_re_anchors_instead_of_bursting():
    throttle = RateThrottle(1.0)
    assert passed(throttle, [0.0, 0.2]) == [0.0]
    # Nobody wanted frames from 0.2 to 5.0 s: the next frame passes, then one per second again.
    assert passed(throttle, [5.2, 5.4, 5.6, 6.0, 6.2, 6.4]) == [5.2, 6.2]


def test_rate_changes_count_from_the_last_frame_passed():
    throttle = RateThrottle(0.5)
    assert passed(throttle, [0.0, 0.2, 0.4]) == [0.0]
    throttle.set_rate(5.0)           # higher: applies at once (next slot 0.2 after 0.0)
    assert passed(throttle, [0.6, 0.8]) == [0.6, 0.8]
    throttle.set_rate(1.0)           # lower: the next slot is 1 s after the last frame passed
    assert passed(throttle, [1.0, 1.2, 1.6, 1.8]) == [1.8]
    throttle.set_rate(0.0)
    assert passed(throttle, [2.0, 2.2]) == [2.0, 2.2]


def test_reset_lets_the_next_frame_through():
    throttle = RateThrottle(1.0)
    assert passed(throttle, [0.0, 0.2]) == [0.0]
    throttle.reset()                  # the scene was reloaded: time starts again at 0
    assert passed(throttle, [0.0, 0.2]) == [0.0]

"""The arm's task state machine without the simulator: fake segments and a fake arm port."""
import subprocess
import sys
from dataclasses import dataclass

import pytest

from pybullet_bridge.core.arm.state_machine import MotionFailure, Mode, PickPlaceRun
from pybullet_bridge.core.arm.task import Outcome, PickPlaceTask


@dataclass
class FakeSegment:
    phase: str
    step: str
    estimate: float
    converges: bool = True
    fails_at_end: str = ''
    duration: float = 0.0
    start_time: float = 0.0
    on_begin: object = None

    def begin(self, arm, sim_time):
        self.start_time, self.duration = sim_time, self.estimate
        if self.on_begin:
            self.on_begin()

    def command(self, arm, sim_time):
        arm.commanded.append(self.step)

    def converged(self, arm):
        return self.converges

    def error_text(self, arm):
        return 'still far'

    def end(self, arm):
        if self.fails_at_end:
            raise MotionFailure(self.fails_at_end)


class FakeArm:
    def __init__(self):
        self.commanded, self.held, self.recoveries = [], False, []
        self.pose = ((0.1, 0.2, 0.415), (0.0, 0.0, 0.0, 1.0))

    def holding(self):
        return self.held

    def recovery_plan(self, put_back):
        self.recoveries.append(put_back)
        return [FakeSegment('retreat', 'return home', 1.0)]

    def drop_plan(self):
        return FakeSegment('release', 'drop the object', 0.4)

    def object_pose(self):
        return self.pose


def make_run(segments, arm=None):
    task = PickPlaceTask('red_1', (0.0, 0.0, 0.3, 0.3), started_at=0.0)
    arm = arm or FakeArm()
    run = PickPlaceRun(task, segments, arm, phase_timeout=0.5, failure_probability=0.0,
                       support_height=0.4, object_edge=0.03)
    return run, task, arm


def drive(run, until=20.0, dt=0.1):
    t = 0.0
    while not run.task.done and t < until:
        run.step(t)
        t = round(t + dt, 9)
    return t


def test_segments_run_in_order_and_the_placement_is_judged():
    run, task, arm = make_run([FakeSegment('approach', 'a', 1.0), FakeSegment('place', 'b', 1.0)])
    assert run.mode is Mode.RUNNING
    drive(run)
    assert task.outcome == Outcome.PLACED and task.message == "'red_1' placed at (0.100, 0.200, 0.415)"
    assert task.progress == 1.0 and run.mode is Mode.DONE
    assert arm.commanded[0] == 'a' and arm.commanded[-1] == 'b'


def test_progress_only_goes_up():
    run, task, _ = make_run([FakeSegment('approach', 'a', 1.0), FakeSegment('place', 'b', 3.0)])
    seen = []
    for i in range(30):
        run.step(i * 0.1)
        seen.append(task.progress)
    assert seen == sorted(seen) and 0.0 < seen[-1] < 1.0


def test_overrun_segment_recovers_and_drops_a_held_object():
    arm = FakeArm()
    arm.held = True
    run, task, _ = make_run([FakeSegment('transport', 'carry', 1.0, converges=False)], arm)
    t = 0.0
    while not run.recovering:
        run.step(t)
        t += 0.1
    assert run.mode is Mode.RECOVERING and arm.recoveries == [False]
    assert [s.step for s in run.segments] == ['drop the object', 'return home']
    assert run.failure.startswith("phase 'transport' (carry) did not finish within 1.5 s of simulated time: still far")
    assert not run.cancel('too late')       # no cancel while recovering
    drive(run)
    assert task.outcome == Outcome.EXECUTION_FAILED and task.message.endswith("; 'red_1' is at (0.100, 0.200, 0.415)")


def test_failure_while_recovering_stops_at_once():
    arm = FakeArm()
    arm.recovery_plan = lambda put_back: [FakeSegment('retreat', 'go home', 1.0, converges=False)]
    run, task, _ = make_run([FakeSegment('approach', 'a', 1.0, fails_at_end='no grasp')], arm)
    drive(run)
    assert task.outcome == Outcome.EXECUTION_FAILED
    assert task.message.startswith("no grasp; then phase 'retreat' (go home) did not finish")
    assert 'the arm stopped where it is' in task.message


def test_cancel_puts_a_held_object_back_and_is_refused_once_released():
    arm = FakeArm()
    arm.held = True
    run, task, _ = make_run([FakeSegment('transport', 'carry', 1.0)], arm)
    run.step(0.0)
    assert run.cancel('canceled by the test') and run.mode is Mode.CANCELED
    assert arm.recoveries == [True] and not run.cancel('again')
    drive(run)
    assert task.outcome == Outcome.ABORTED
    assert task.message == "canceled by the test: 'red_1' was put back; it rests at (0.100, 0.200, 0.415)"

    run, task, _ = make_run([FakeSegment('release', 'open', 1.0), FakeSegment('retreat', 'home', 1.0)])
    run.segments[0].on_begin = run.object_released
    run.step(0.0)
    assert run.released and not run.cancel('too late')


def test_abort_ends_at_once():
    run, task, _ = make_run([FakeSegment('approach', 'a', 1.0)])
    run.step(0.0)
    run.abort('the bridge is shutting down')
    assert task.outcome == Outcome.ABORTED and task.message == 'the bridge is shutting down'
    assert run.segments == [] and run.segment is None


def test_the_state_machine_and_scenarios_need_no_simulator():
    # A fresh interpreter: this test process has pybullet loaded by other tests.
    code = ('import sys; import pybullet_bridge.core.arm.state_machine, pybullet_bridge.core.arm.requests, '
            'pybullet_bridge.core.arm.outcome, pybullet_bridge.core.scenario, pybullet_bridge.core.frames; '
            'print("pybullet" in sys.modules)')
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == 'False'


@pytest.mark.parametrize('orientation, tilted', [((0.0, 0.0, 0.0, 1.0), False), ((0.2588, 0.0, 0.0, 0.9659), True)])
def test_tilt_is_judged_from_the_orientation(orientation, tilted):
    arm = FakeArm()
    arm.pose = ((0.1, 0.2, 0.415), orientation)
    run, task, _ = make_run([FakeSegment('place', 'b', 1.0)], arm)
    drive(run)
    assert (task.outcome == Outcome.EXECUTION_FAILED) == tilted
    if tilted:
        assert 'tilted 30 deg' in task.message

"""Motor schemas on a unicycle model: go to goal, heading from motion, box pushing with the
teammate's bumper as the synchronisation signal, a helper keeping the leader in view."""
from __future__ import annotations

import math

import pytest

from coalition_agents.core.errors import ConfigError
from coalition_agents.core.motor_schema import (
    BoxPush, GoToGoal, HeadingEstimator, MaintainRelativePosition, STOP, Velocity,
)

DT = 0.1


def step(pose, command, dt=DT):
    x, y, yaw = pose
    return (x + command.linear * math.cos(yaw) * dt, y + command.linear * math.sin(yaw) * dt,
            yaw + command.angular * dt)


@pytest.mark.parametrize('start, goal', [((0.0, 0.0, 0.0), (3.0, 2.0)), ((1.0, 1.0, math.pi), (4.0, 1.0)),
                                         ((0.0, 0.0, 2.0), (-2.0, -3.0))])
def test_go_to_goal_reaches_the_goal_with_a_known_heading(start, goal):
    drive, pose = GoToGoal(), start
    for _ in range(600):
        command = drive.command(pose[:2], pose[2], goal)
        if command == STOP:
            break
        pose = step(pose, command)
    assert drive.distance(pose[:2], goal) <= drive.tolerance
    assert command == STOP


def test_the_heading_probe_keeps_to_the_speed_limit():
    # max_speed is a dynamic parameter of schema_agent: a limit below the probe speed holds for the probe too.
    drive = GoToGoal(max_speed=0.05)
    assert drive.command((0.0, 0.0), None, (3.0, 0.0)) == Velocity(0.05, 0.0)


def test_go_to_goal_with_the_heading_estimated_from_motion_only():
    # The robot is localised by a teammate's fiducial (position only): first it drives straight to
    # learn its heading, then it steers on the estimate.
    drive, estimator, pose, command = GoToGoal(), HeadingEstimator(min_step=0.1), (0.0, 0.0, 2.5), STOP
    assert drive.command(pose[:2], None, (3.0, 0.0)) == Velocity(drive.probe_speed, 0.0)
    for _ in range(1500):
        estimator.commanded(command, DT)
        heading = estimator.fix(*pose[:2])
        command = drive.command(pose[:2], heading, (3.0, 0.0))
        if command == STOP:
            break
        pose = step(pose, command)
    assert drive.distance(pose[:2], (3.0, 0.0)) <= drive.tolerance


def test_heading_estimate_is_the_direction_of_the_displacement():
    estimator = HeadingEstimator(min_step=0.2)
    assert estimator.fix(0.0, 0.0) is None
    assert estimator.fix(0.1, 0.1) is None  # not far enough yet
    assert estimator.fix(0.2, 0.2) == pytest.approx(math.pi / 4)
    estimator.commanded(Velocity(0.0, 1.0), 0.5)
    assert estimator.heading == pytest.approx(math.pi / 4 + 0.5)
    estimator.measured(7.0)
    assert estimator.heading == pytest.approx(7.0 - 2 * math.pi)


class PushWorld:
    """A box that moves with a robot pressing on its back face (kinematic, for the MS logic)."""

    def __init__(self, box, robot, standoff):
        self.box, self.robot, self.standoff = list(box), robot, standoff

    def pressed(self):
        return math.hypot(self.box[0] - self.robot[0], self.box[1] - self.robot[1]) <= self.standoff + 1e-6

    def step(self, command):
        self.robot = step(self.robot, command)
        gap = math.hypot(self.box[0] - self.robot[0], self.box[1] - self.robot[1])
        if gap < self.standoff:  # the robot pushes the box ahead of it
            ux, uy = (self.box[0] - self.robot[0]) / gap, (self.box[1] - self.robot[1]) / gap
            self.box = [self.robot[0] + ux * self.standoff, self.robot[1] + uy * self.standoff]


def test_box_push_brings_the_box_to_the_goal_from_a_side_start():
    world, push, goal = PushWorld((1.0, 0.0), (1.0, -1.5, 0.0), standoff=0.5), BoxPush(standoff=0.5), (3.0, 1.0)
    phases = []
    for _ in range(3000):
        command, state = push.command(world.robot[:2], world.robot[2], world.box, goal, world.pressed(), True)
        phases.append(state.phase)
        if state.phase == 'done':
            break
        world.step(command)
    assert phases[-1] == 'done' and math.hypot(goal[0] - world.box[0], goal[1] - world.box[1]) <= push.tolerance
    assert phases[0] == 'approach' and 'push' in phases


def test_box_push_waits_for_the_teammate_bumper():
    push = BoxPush(standoff=0.5)
    push.phase = 'push'
    command, state = push.command((0.5, 0.0), 0.0, (1.0, 0.0), (3.0, 0.0), pressed=True, teammate_pressed=False)
    assert command == STOP and state.phase == 'wait_teammate'
    command, state = push.command((0.5, 0.0), 0.0, (1.0, 0.0), (3.0, 0.0), pressed=True, teammate_pressed=True)
    assert command.linear > 0 and state.phase == 'push'
    # Not yet touching: creep forward into contact (the teammate's state does not matter yet).
    command, state = push.command((0.45, 0.0), 0.0, (1.0, 0.0), (3.0, 0.0), pressed=False, teammate_pressed=False)
    assert 0 < command.linear < push.max_speed


def test_helper_keeps_the_leader_at_its_relative_position():
    follow = MaintainRelativePosition(target=(1.5, 0.0))
    leader, helper = (1.5, 0.0, 0.0), (0.0, 0.0, 0.0)
    for _ in range(400):
        leader = step(leader, Velocity(0.2, 0.15))
        dx, dy = leader[0] - helper[0], leader[1] - helper[1]
        c, s = math.cos(-helper[2]), math.sin(-helper[2])
        helper = step(helper, follow.command((c * dx - s * dy, s * dx + c * dy)))
    seen_x = math.cos(-helper[2]) * (leader[0] - helper[0]) - math.sin(-helper[2]) * (leader[1] - helper[1])
    assert math.hypot(leader[0] - helper[0], leader[1] - helper[1]) == pytest.approx(1.5, abs=0.35)
    assert seen_x > 1.0  # still ahead, in view


def test_a_helper_that_lost_sight_of_the_leader_turns_towards_where_it_last_saw_it():
    assert MaintainRelativePosition(target=(0.0, 0.6)).command(None) == STOP  # never seen: wait
    left, right = MaintainRelativePosition(target=(0.0, 0.6)), MaintainRelativePosition(target=(0.5, -0.6))
    left.command((0.0, 0.6))
    right.command((0.5, -0.6))
    assert left.command(None).linear == 0.0 and left.command(None).angular > 0
    assert right.command(None).linear == 0.0 and right.command(None).angular < 0
    # A pushing teammate keeps the leader abeam, at the edge of a 170 deg field of view: when the
    # leader drops behind that edge the helper turns until it sees it again (it used to stop,
    # and the leader waited for it for ever).
    follow = MaintainRelativePosition(target=(0.0, 0.6))
    follow.command((0.0, 0.6))                          # seen abeam, on the left
    helper, leader = (0.0, 0.0, 0.0), (-0.15, 0.6)      # then it dropped behind the edge of the view

    def in_view():
        dx, dy = leader[0] - helper[0], leader[1] - helper[1]
        bearing = math.atan2(dy, dx) - helper[2]
        return abs(math.atan2(math.sin(bearing), math.cos(bearing))) <= math.radians(85.0)
    assert not in_view()
    for _ in range(100):
        helper = step(helper, follow.command(None))
        if in_view():
            break
    assert in_view() and helper[2] > 0                 # it turned left and sees the leader again
    assert helper[:2] == (0.0, 0.0)                    # on the spot: it does not push blindly


def test_bad_gains_are_rejected_with_the_parameter_name():
    with pytest.raises(ConfigError, match='motor_schema.max_speed: must be a number > 0'):
        GoToGoal(max_speed=-1.0)
    with pytest.raises(ConfigError, match='motor_schema.standoff'):
        BoxPush(standoff=0.0)


def test_a_pusher_already_behind_the_box_aligns_instead_of_going_around():
    push = BoxPush(standoff=0.5, lateral_offset=0.3)
    _, state = push.command((0.42, 0.3), 0.4, (1.0, 0.0), (3.5, 0.0), pressed=False, teammate_pressed=None)
    assert state.phase == 'align'
    _, state = BoxPush(standoff=0.5).command((2.0, 0.0), 0.0, (1.0, 0.0), (3.5, 0.0), False, None)
    assert state.phase == 'approach'  # in front of the box: go around it


def test_a_pushing_teammate_creeps_into_contact_then_keeps_pressing():
    follow = MaintainRelativePosition(target=(0.0, 0.6), creep_speed=0.08)
    # The leader waits (it has not moved): out of contact the teammate still moves forward ...
    assert follow.command((0.0, 0.6), pressed=False).linear == pytest.approx(0.08)
    # ... in contact it keeps pressing, and keeps pace when the leader pushes ahead.
    assert follow.command((-0.05, 0.6), pressed=True).linear == pytest.approx(0.08)
    assert follow.command((0.2, 0.6), pressed=True).linear == pytest.approx(0.24)
    # A plain helper (no bumper) at its place stops.
    assert follow.command((0.0, 0.6)) == STOP

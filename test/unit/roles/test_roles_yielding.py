"""Yielding in a one-lane hallway (core/yielding.py through the role-playing update, Sec. V-A-4).

Two burgers (r = 0.105 m) swap rooms through a hallway 0.35 m wide, narrower than both
side by side. Like the role players they re-plan once per second while following their
roles exactly, either both from the same snapshot of the channel (simultaneous) or one
after the other (alternating). The roles they follow must never bring them closer than
r_i + r_j, never put a centre into an inflated wall, and exactly one of them must wait.
"""
import math

import numpy as np
import pytest

from role_engine.core.conflict import SharedRole
from role_engine.core.environment import Environment, RobotType
from role_engine.core.gp_planner import GPPlanner, GPPlannerConfig
from role_engine.core.initial_paths import straight_line_trajectory
from role_engine.core.role_playing import role_gaps, replan_process_role
from role_engine.core.yielding import pair_conflict, right_of_way, waiting_plans

RADIUS = 0.105
TOTAL_TIME = 45.0
STATES = 46
WEST, EAST = (-2.0, 0.0), (2.0, 0.0)
#: config/roles/hallway_swap.yaml's GP settings; speed limit 0.8 x the burger's 0.22 m/s.
CONFIG = GPPlannerConfig(qc=1.0, sigma_obs=0.1, epsilon=0.05, lambda_initial=1000.0, max_iterations=50,
                         relative_error_tol=1e-4, max_speed=0.176)
BURGER = RobotType('burger', RADIUS, inflation_margin=0.03, max_linear_velocity=0.22)


def two_rooms():
    """Two 1.6 x 2 m rooms joined by a 1.8 m hallway 0.35 m wide (config/roles/hallway_scenario.yaml)."""
    resolution, origin = 0.025, (-2.5, -1.0)
    iy, ix = np.mgrid[0:80, 0:200]
    x, y = origin[0] + (ix + 0.5) * resolution, origin[1] + (iy + 0.5) * resolution
    occupied = (np.abs(x) <= 0.9) & (np.abs(y) >= 0.18)
    return Environment(occupied, resolution, origin)


@pytest.fixture(scope='module')
def env():
    return two_rooms().for_robot(BURGER)


def initial_role(env, name, start, goal):
    planned = GPPlanner(CONFIG, env.sdf).plan(straight_line_trajectory(start, goal, TOTAL_TIME, STATES - 1),
                                              TOTAL_TIME)
    assert planned.collision_free                     # the hallway passes the inflation: one robot fits
    return SharedRole(name, planned.trajectory, TOTAL_TIME, RADIUS)


def play(env, roles, *, simultaneous, until=60.0, period=1.0):
    """Re-plan every ``period`` s up to ``until``; returns the roles followed and every Replan by robot."""
    followed, replans = [], {role.name: [] for role in roles}
    now = period
    while now <= until:
        snapshot = list(roles)
        for me in range(len(roles)):
            own = roles[me]
            channel = snapshot if simultaneous else roles
            others = [role for role in channel if role.name != own.name]
            result = replan_process_role(CONFIG, env, own, others, now, own.positions([now])[0], horizon=4.0)
            replans[own.name].append(result)
            if result.trajectory is not None:
                roles[me] = SharedRole(own.name, result.trajectory, result.total_time, RADIUS, result.start_time)
        times = np.linspace(now, now + period, 21)
        followed.append((times, [role.positions(times) for role in roles]))
        now += period
    end = max(role.start_time + role.total_time for role in roles) + 1.0
    times = np.linspace(now, end, int((end - now) * 20) + 2)
    followed.append((times, [role.positions(times) for role in roles]))
    return roles, followed, replans


def longest_wait(followed, index, goal):
    """Longest stretch [s] robot ``index`` stands still (< 0.01 m/s) on the roles followed, before arriving."""
    times = np.concatenate([t[:-1] for t, _ in followed])
    positions = np.concatenate([pair[index][:-1] for _, pair in followed])
    speeds = np.hypot(*np.diff(positions, axis=0).T) / np.diff(times)
    away = np.hypot(*(positions[:-1] - goal).T) > 0.05
    best = run = 0.0
    for still, dt in zip((speeds < 0.01) & away, np.diff(times)):
        run = run + dt if still else 0.0
        best = max(best, run)
    return best


@pytest.mark.parametrize('simultaneous', [True, False], ids=['same snapshot', 'alternating'])
def test_one_lane_hallway_swap_one_robot_waits_and_nobody_touches(env, simultaneous):
    roles = [initial_role(env, 'west', WEST, EAST), initial_role(env, 'east', EAST, WEST)]
    before = role_gaps(roles[0].trajectory, 0.0, TOTAL_TIME, RADIUS, [roles[1]])['east']
    assert before < 0.0                                       # the initial roles meet head-on in the hallway
    roles, followed, replans = play(env, roles, simultaneous=simultaneous)
    distance = min(float(np.min(np.hypot(*(a - b).T))) for _, (a, b) in followed)
    wall = min(float(env.sdf.distance(positions).min()) for _, pair in followed for positions in pair)
    yielded = {name: [r for r in results if r.yielding_to] for name, results in replans.items()}
    print(f"{'same snapshot' if simultaneous else 'alternating'}: min distance {distance:.3f} m "
          f"(r_i + r_j = {2 * RADIUS:.3f}), min wall clearance of the centres {wall:.3f} m, yields "
          f"{ {n: len(y) for n, y in yielded.items()} }, first: "
          f"{next(r.initialisation for y in yielded.values() for r in y)}")
    assert distance >= 2 * RADIUS
    assert wall >= 0.0                                        # centres never inside an inflated wall
    waiters = [name for name, results in yielded.items() if results]
    assert len(waiters) == 1                                  # exactly one gives way ...
    waiter = waiters[0]
    keeper = next(name for name in replans if name != waiter)
    assert all(r.yielding_to == [keeper] for r in yielded[waiter])
    by_name = {role.name: role for role in roles}
    goals = {'west': EAST, 'east': WEST}
    waited = {name: longest_wait(followed, index, goals[name]) for index, name in enumerate(('west', 'east'))}
    print(f'longest waits before arriving: {waited}')
    assert waited[waiter] >= 3.0 and waited[keeper] < 1.0   # ... and really stands still, the other does not
    assert by_name[waiter].start_time + by_name[waiter].total_time > TOTAL_TIME   # its role was extended
    assert by_name[keeper].start_time + by_name[keeper].total_time == pytest.approx(TOTAL_TIME)
    for role, goal in ((by_name[name], goal) for name, goal in goals.items()):
        np.testing.assert_allclose(role.positions([role.start_time + role.total_time])[0], goal, atol=1e-3)
        speeds = np.hypot(*role.trajectory[:, 2:].T)
        assert speeds.max() <= CONFIG.max_speed * 1.05          # the waiting plan respects the speed limit


def test_right_of_way_is_symmetric_and_ties_go_by_name(env):
    west, east = initial_role(env, 'west', WEST, EAST), initial_role(env, 'east', EAST, WEST)
    first, second = pair_conflict(west, east, env, 1.0, 0.1), pair_conflict(east, west, env, 1.0, 0.1)
    assert first == second and first.narrow
    assert math.isclose(first.entry_times['west'], first.entry_times['east'], abs_tol=0.11)
    assert right_of_way(west, east, env, 1.0, 0.1) is not right_of_way(east, west, env, 1.0, 0.1)
    if first.entry_times['west'] == first.entry_times['east']:
        assert first.keeps_role == 'east'                       # the name that sorts first


def test_the_robot_already_in_the_hallway_keeps_its_role(env):
    # 'zulu' (sorting last, so the name would not favour it) is inside the hallway; 'alpha' is in its room.
    zulu = initial_role(env, 'zulu', (0.5, 0.0), WEST)
    alpha = initial_role(env, 'alpha', (-2.2, 0.0), EAST)
    conflict = pair_conflict(alpha, zulu, env, 0.0, 0.1)
    print(f'entry times {conflict.entry_times}, meeting point {conflict.meeting_point}')
    assert conflict.narrow and conflict.entry_times['zulu'] == 0.0 < conflict.entry_times['alpha']
    assert right_of_way(zulu, alpha, env, 0.0, 0.1) is True and right_of_way(alpha, zulu, env, 0.0, 0.1) is False


def test_in_the_open_a_conflict_area_is_a_disc_around_the_meeting_point():
    open_env = Environment(np.zeros((80, 80), dtype=bool), 0.05, (-2.0, -2.0)).for_robot(BURGER)
    a = SharedRole('a', straight_line_trajectory((-1.5, 0.0), (1.5, 0.0), 20.0, 20), 20.0, RADIUS)
    b = SharedRole('b', straight_line_trajectory((1.5, 0.0), (-1.5, 0.0), 20.0, 20), 20.0, RADIUS)
    conflict = pair_conflict(a, b, open_env, 0.0, 0.1)
    assert not conflict.narrow
    np.testing.assert_allclose(conflict.meeting_point, (0.0, 0.0), atol=0.05)
    far = SharedRole('far', straight_line_trajectory((-1.5, 1.5), (1.5, 1.5), 20.0, 20), 20.0, RADIUS)
    assert pair_conflict(a, far, open_env, 0.0, 0.1) is None and right_of_way(a, far, open_env, 0.0, 0.1) is None


def test_waiting_spots_are_off_the_other_path_in_free_space_and_released_after_it_passed(env):
    east = initial_role(env, 'east', EAST, WEST)
    plans = waiting_plans(env, RADIUS, (-1.8, 0.0), EAST, 1.0, [east], [east], clearance=0.1, speed=0.14,
                          spot_clearance=CONFIG.epsilon)
    assert plans
    times = np.arange(1.0, 80.0, 0.1)
    path = east.positions(np.linspace(0.0, TOTAL_TIME, 500))
    for plan in plans:
        print(plan.label, f'finish {plan.finish:.1f} s')
        assert np.min(np.hypot(*(path - plan.spot).T)) >= 2 * RADIUS + 0.1
        assert env.sdf.distance(np.array([plan.spot]))[0] >= CONFIG.epsilon
        gap = np.hypot(*(plan.positions(times) - east.positions(times)).T) - 2 * RADIUS
        assert gap.min() >= 0.1
        assert plan.arrive <= plan.release < plan.finish
        np.testing.assert_allclose(plan.positions([plan.finish + 1.0])[0], EAST)
    assert [p.finish for p in plans] == sorted(p.finish for p in plans)

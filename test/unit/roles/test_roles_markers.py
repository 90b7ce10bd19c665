"""Role engine markers from its messages (plain stand-ins): the E-Map of each robot type on the
published map, assigned roles at their goals, and each process role with the state of 'now'."""
from types import SimpleNamespace as Msg

import numpy as np
import pytest

from role_engine.core.emap import build_emap
from role_engine.core.environment import RobotType
from role_engine.core.markers import RoleMarkers, role_state_at
from role_engine.core.occupancy import occupancy_cells
from roles_map_helpers import environment, ring_corridor


def grid_msg(env):
    cells = occupancy_cells(env)
    return Msg(info=Msg(width=cells.width, height=cells.height, resolution=cells.resolution,
                        origin=Msg(position=Msg(x=cells.origin[0], y=cells.origin[1]),
                                   orientation=Msg(x=0.0, y=0.0, z=0.0, w=1.0))),
               data=cells.data.tolist())


def team(*members):
    return Msg(members=[Msg(name=n, robot_type=t, radius=r, color=c) for n, t, r, c in members])


def role(robot, x, y, start=10.0, dt=0.5, round_=1, version=0):
    return Msg(robot=robot, role_id=f'{robot}_role', round=round_, version=version, start_time=start, dt=dt,
               x=list(x), y=list(y))


TEAM = team(('pioneer_1', 'pioneer_3dx', 0.23, (1.0, 0.0, 0.0)), ('burger_1', 'turtlebot3_burger', 0.105,
                                                                  (0.0, 0.0, 1.0)))


def test_an_emap_per_robot_type_as_the_engine_builds_it():
    env = environment(ring_corridor())
    source = RoleMarkers()
    source.on_map(grid_msg(env))
    source.on_team(TEAM)
    specs = source.markers(0.0)
    for kind, radius in (('pioneer_3dx', 0.23), ('turtlebot3_burger', 0.105)):
        reference = build_emap(env.for_robot(RobotType(kind, radius)))
        edges = next(s for s in specs if s.ns == f'emap/{kind}' and s.kind == 'line_list')
        nodes = next(s for s in specs if s.ns == f'emap/{kind}' and s.kind == 'sphere_list')
        assert len(edges.points) == 2 * reference.graph.number_of_edges() > 0
        drawn = np.array(sorted(p[:2] for p in nodes.points))
        assert drawn == pytest.approx(np.array(sorted(reference.position(n) for n in reference.node_ids)))


def test_assigned_roles_at_their_goals_in_their_robots_colours():
    source = RoleMarkers()
    source.on_team(TEAM)
    source.on_assignment(Msg(round=1, status='assigned', message='', robots=['pioneer_1', 'burger_1'],
                             role_ids=['diamond_0', 'diamond_1'], goal_x=[1.0, 2.0], goal_y=[0.5, -0.5],
                             initial_roles=[role('pioneer_1', [0, 1], [0, 0.5])]))
    specs = source.markers(10.0)
    goals = {s.id: s for s in specs if s.ns == 'goals'}
    assert goals[0].position[:2] == (1.0, 0.5) and goals[0].color[:3] == (1.0, 0.0, 0.0)
    assert goals[1].color[:3] == (0.0, 0.0, 1.0)
    assert {s.text for s in specs if s.ns == 'roles'} >= {'pioneer_1: diamond_0', 'burger_1: diamond_1'}
    assert [s.ns for s in specs].count('process_roles') == 1  # the initial role of the assignment


def test_the_current_state_moves_along_the_time_indexed_path():
    r = role('burger_1', [0.0, 1.0, 2.0], [0.0, 0.0, 1.0], start=10.0, dt=0.5)
    assert role_state_at(r, 9.0) == (0.0, 0.0)              # before the start: the first state
    assert role_state_at(r, 10.25) == pytest.approx((0.5, 0.0))
    assert role_state_at(r, 10.75) == pytest.approx((1.5, 0.5))
    assert role_state_at(r, 99.0) == (2.0, 1.0)             # after the end: the last
    source = RoleMarkers()
    source.on_process_role(r)
    source.on_process_role(role('burger_1', [5.0, 6.0], [5.0, 5.0], version=1))  # re-optimised: replaces
    source.on_process_role(role('burger_1', [9.0, 9.0], [9.0, 9.0], version=0))  # older: ignored
    [now] = [s for s in source.markers(10.0) if s.ns == 'now']
    assert now.position[:2] == (5.0, 5.0)
    assert source.time_dependent


def test_malformed_roles_and_assignments_are_refused_naming_the_field():
    source = RoleMarkers()
    with pytest.raises(ValueError, match='parallel arrays'):
        source.on_process_role(role('burger_1', [0.0, 1.0], [0.0]))
    with pytest.raises(ValueError, match='dt'):
        source.on_process_role(role('burger_1', [0.0], [0.0], dt=0.0))
    with pytest.raises(ValueError, match='roles/assignment'):
        source.on_assignment(Msg(round=1, status='assigned', message='', robots=['a'], role_ids=[], goal_x=[1.0],
                                 goal_y=[1.0], initial_roles=[]))
    assert source.markers(0.0) is None
    bad_map = grid_msg(environment(np.zeros((4, 4), dtype=bool)))
    bad_map.data = bad_map.data[:-1]
    with pytest.raises(ValueError):
        source.on_map(bad_map)

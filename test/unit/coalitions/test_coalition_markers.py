"""Coalition markers from the agents' statuses (plain stand-ins): a line from each helper to the
leader it serves with what it shares, every robot's state, the fiducials' fields of view."""
import math
from types import SimpleNamespace as Msg

import pytest

from coalition_agents.core.markers import CoalitionMarkers, describe_use, help_links

COMMITTED, SEARCHING, IDLE = 4, 2, 0


def status(robot, state, coalition='', leader='', commitments=()):
    return Msg(robot=robot, state=state, coalition_id=coalition, leader=leader, commitments=list(commitments))


def commitment(cid, leader, uses):
    return Msg(coalition_id=cid, leader=leader, members=[], uses=list(uses))


def bodies(**positions):
    return Msg(bodies=[Msg(name=n, pose=Msg(position=Msg(x=x, y=y))) for n, (x, y) in positions.items()])


def test_a_line_from_each_helper_to_its_leader_with_what_it_shares():
    source = CoalitionMarkers()
    source.on_bodies(bodies(blind=(0.0, 0.0), helper=(2.0, 0.0), bystander=(5.0, 5.0), box=(float('nan'), 0.0)))
    source.on_status(status('blind', COMMITTED, 'c1', 'blind', [commitment('c1', 'blind', ['motor:go_to:own task'])]))
    source.on_status(status('helper', COMMITTED, 'c1', 'blind',
                            [commitment('c1', 'blind', ['sensor:fiducial:F_R(blind,helper)',
                                                        'information:F_G(blind)'])]))
    source.on_status(status('bystander', IDLE))
    specs = source.markers()
    [line] = [s for s in specs if s.ns == 'helps']
    assert [p[:2] for p in line.points] == [(2.0, 0.0), (0.0, 0.0)]  # helper -> leader
    [label] = [s for s in specs if s.ns == 'uses']
    assert label.text == 'fiducial: F_R(blind,helper), F_G(blind)' and label.position[:2] == (1.0, 0.0)
    assert label.color == line.color
    states = {s.text for s in specs if s.ns == 'states'}
    assert states == {'blind: COMMITTED [c1]', 'helper: COMMITTED [c1]', 'bystander: IDLE'}
    assert 'box' not in source.positions


def test_a_helper_of_two_leaders_gets_two_lines_in_two_colours():
    statuses = {'h': status('h', COMMITTED, 'a', 'l1', [commitment('a', 'l1', ['information:F_G(l1)']),
                                                       commitment('b', 'l2', ['information:F_G(l2)'])])}
    assert [(h, l, c) for h, l, c, _ in help_links(statuses)] == [('h', 'l1', 'a'), ('h', 'l2', 'b')]
    source = CoalitionMarkers()
    source.statuses = statuses
    source.on_bodies(bodies(h=(0, 0), l1=(1, 0), l2=(0, 1)))
    lines = [s for s in source.markers() if s.ns == 'helps']
    assert len(lines) == 2 and lines[0].color != lines[1].color


def test_uses_read_as_words():
    assert describe_use('information:F_R(X,robot_1)') == 'F_R(X,robot_1)'
    assert describe_use('aimed_sensor:camera:F_G(X)') == 'camera: F_G(X)'
    assert describe_use('motor:follow:robot_2') == 'follow (robot_2)'
    assert describe_use('something') == 'something'


def test_a_sensors_field_of_view_is_a_wedge_in_its_own_frame():
    source = CoalitionMarkers()
    reading = Msg(header=Msg(frame_id='helper/fiducial_link'), field_of_view=math.radians(60), max_range=1.5,
                  detections=[Msg(x=1.0, y=0.2), Msg(x=float('nan'), y=0.0)])
    source.on_fiducials(reading, '/helper/fiducials')
    specs = source.markers()
    [wedge] = [s for s in specs if s.ns == 'fov']
    [seen] = [s for s in specs if s.ns == 'seen']
    assert wedge.frame == seen.frame == 'helper/fiducial_link'
    ranges = [math.hypot(x, y) for x, y, _ in wedge.points]
    bearings = [math.atan2(y, x) for x, y, _ in wedge.points if math.hypot(x, y) > 0]
    assert max(ranges) == pytest.approx(1.5) and max(bearings) == pytest.approx(math.radians(30))
    assert seen.points == ((1.0, 0.2, 0.1),)
    source.on_fiducials(Msg(header=Msg(frame_id=''), field_of_view=1.0, max_range=1.0, detections=[]), '/x')
    with pytest.raises(ValueError, match='frame_id'):  # the visualiser drops it, counted and logged
        source.markers()


def test_nothing_to_show_without_statuses_and_a_status_names_its_robot():
    source = CoalitionMarkers()
    assert source.markers() is None
    with pytest.raises(ValueError, match='robot'):
        source.on_status(status('', SEARCHING))

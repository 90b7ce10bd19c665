"""SGCM markers from a Guidance (plain stand-ins for the messages): the grid where the task puts it,
one estimate cube per object the leader saw, the recommendation as an arrow between cell centres."""
from pathlib import Path
from types import SimpleNamespace as Msg

import pytest

from sgcm.core.markers import SgcmMarkers, grid_markers, guidance_markers

TASK_FILE = Path(__file__).resolve().parents[3] / 'config' / 'sgcm' / 'task.yaml'
EMPTY = Msg(empty=True, source_cell=0, target_cell=0, colour='')


def guidance(counts, recommended=EMPTY, leader=EMPTY, **fields):
    values = dict(round=2, horizon=2, strategy='sgcm', state=Msg(rows=3, cols=3, colours=['red', 'green', 'blue'],
                                                                 counts=counts),
                  leader_move=leader, leader_policy_moves=[], leader_policy_probabilities=[],
                  recommended_follower_move=recommended, task_complete=False, status='')
    values.update(fields)
    return Msg(**values)


def counts_with(*entries):
    counts = [0] * 27
    for cell, colour, n in entries:
        counts[cell * 3 + colour] = n
    return counts


@pytest.fixture
def source():
    return SgcmMarkers(task_file=str(TASK_FILE))


def test_the_grid_lies_where_the_task_puts_it(source):
    task = source.task
    specs = grid_markers(task, 'world')
    lines = next(s for s in specs if s.ns == 'grid')
    xs = [p[0] for p in lines.points]
    half = task.cols * task.workspace.cell_size / 2
    assert min(xs) == pytest.approx(task.workspace.center[0] - half)
    assert max(xs) == pytest.approx(task.workspace.center[0] + half)
    assert len(lines.points) == 2 * 4 * task.cells
    assert [p[2] for p in lines.points] == pytest.approx([task.workspace.table_height + 0.002] * len(lines.points))
    goals = [s for s in specs if s.ns == 'goals']
    assert len(goals) == 3 and goals[0].color[:3] == pytest.approx(task.colour_rgb[0])


def test_one_cube_per_object_and_the_recommendation_between_cell_centres(source):
    task = source.task
    move = Msg(empty=False, source_cell=0, target_cell=6, colour='red')
    source.on_guidance(guidance(counts_with((0, 0, 2), (4, 2, 1)), recommended=move))
    specs = source.markers()
    [estimate] = [s for s in specs if s.ns == 'estimate']
    assert len(estimate.points) == 3
    assert estimate.colors.count(pytest.approx(estimate.colors[0])) == 2  # two red, one blue
    texts = {s.id: s.text for s in specs if s.ns == 'counts'}
    assert texts == {0: '2 red', 4: '1 blue'}
    [arrow] = [s for s in specs if s.ns == 'recommended']
    (x0, y0, _), (x1, y1, _) = arrow.points
    cell0, cell6 = task.workspace.cell_region(3, 3, 0), task.workspace.cell_region(3, 3, 6)
    assert (x0, y0) == pytest.approx(((cell0[0] + cell0[2]) / 2, (cell0[1] + cell0[3]) / 2))
    assert (x1, y1) == pytest.approx(((cell6[0] + cell6[2]) / 2, (cell6[1] + cell6[3]) / 2))
    assert y1 < y0  # row 2 is at -y (the bottom of the image)
    assert arrow.color[:3] == pytest.approx(task.colour_rgb[0])
    assert not [s for s in specs if s.ns == 'leader_move']  # her empty move draws nothing
    status = next(s for s in specs if s.ns == 'status').text
    assert 'round 2' in status and 'red (0,0) -> (2,0)' in status


def test_the_followers_answer_and_the_policy_are_shown(source):
    task = source.task
    moves = [Msg(empty=False, source_cell=1, target_cell=4, colour='green'),
             Msg(empty=False, source_cell=1, target_cell=2, colour='green')]
    source.on_guidance(guidance(counts_with((1, 1, 1)), leader=moves[0], leader_policy_moves=moves,
                                leader_policy_probabilities=[0.75, 0.25]))
    source.on_report(Msg(round=2, behaviour='random', move=moves[1], deviated=True))
    specs = guidance_markers(task, source.guidance, source.report)
    policy = sorted((s for s in specs if s.ns == 'leader_policy'), key=lambda s: s.id)
    assert [s.color[3] for s in policy] == [0.75, 0.25]
    assert 'follower (random): green (0,1) -> (0,2) (deviated)' in next(s for s in specs if s.ns == 'status').text


def test_a_malformed_estimate_is_refused_naming_the_field(source):
    with pytest.raises(ValueError, match='guidance.state.counts'):
        source.on_guidance(guidance([1, 2, 3]))
    with pytest.raises(ValueError, match='guidance.state: grid 2 x 3'):
        source.on_guidance(guidance(counts_with(), state=Msg(rows=2, cols=3, colours=['red'], counts=[0] * 6)))
    bad_move = Msg(empty=False, source_cell=0, target_cell=42, colour='red')
    with pytest.raises(ValueError, match='recommended.target_cell: 42'):
        guidance_markers(source.task, guidance(counts_with(), recommended=bad_move))


def test_without_a_task_nothing_is_drawn_until_the_leaders_task_file_arrives():
    source = SgcmMarkers()
    assert source.wants_parameter('task_file')
    source.on_guidance(guidance(counts_with((0, 0, 1))))
    assert source.markers() is None
    source.set_parameter('task_file', str(TASK_FILE))
    assert not source.wants_parameter('task_file')
    assert any(s.ns == 'estimate' for s in source.markers())

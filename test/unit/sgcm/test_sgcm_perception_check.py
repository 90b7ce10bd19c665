"""Perception judges its own evidence (issue 16 item 3): empty, truncated, unknown-label and no-cube
frames are rejected and never yield "goal reached"; rejections for long enough are a perception fault."""
from pathlib import Path

import numpy as np
import pytest
from sensor_msgs.msg import Image

from collab_tools.images import image_array
from pybullet_bridge.core import Scene, parse_scenario
from sgcm.core.fse import FSEPlanner
from sgcm.core.leader_round import Ending, LeaderRound
from sgcm.core.leader_rounds import LeaderPhase, LeaderRounds
from sgcm.core.perception import StateEstimate, estimate_state
from sgcm.core.perception_check import PerceptionCheck, evidence_problem
from sgcm.core.scenario_builder import build_scenario


@pytest.fixture(scope='module')
def rendered(task, cases):
    case = cases[0]
    with Scene(parse_scenario(build_scenario(task, case), Path('.'))) as scene:
        frame = scene.render()
        cube_labels = {label: name for label, name, kind in scene.label_legend() if kind == 'cube'}
        return case, frame.labels.copy(), frame.rgb.copy(), cube_labels, scene.camera.geometry


def estimate(task, labels, rgb, cube_labels, geometry):
    ws = task.workspace
    return estimate_state(labels, rgb, cube_labels, geometry, task, top_height=ws.table_height + ws.cube_size)


def garbage_frames(labels, rgb, cube_labels):
    """name -> (labels, rgb) of frames that show the table wrongly or not at all."""
    no_cube = labels.copy()
    no_cube[np.isin(no_cube, list(cube_labels))] = 0                 # the camera sees no cube
    rows = np.nonzero(np.isin(labels, list(cube_labels)).any(axis=1))[0]
    truncated = (labels[:rows.min()].copy(), rgb[:rows.min()].copy())   # ends before the first cube row
    cut = (rows.min() + rows.max()) // 2                                # cut through the cubes: some lost
    return {
        'empty 0x0': (np.zeros((0, 0), dtype=np.uint16), np.zeros((0, 0, 3), dtype=np.uint8)),
        'no cube visible': (no_cube, rgb),
        'all unknown labels': (np.full_like(labels, 999), rgb),
        'truncated': truncated,
        'cut through the cubes': (labels[:cut].copy(), rgb[:cut].copy()),
    }


def test_a_good_frame_is_evidence(task, rendered):
    case, labels, rgb, cube_labels, geometry = rendered
    seen = estimate(task, labels, rgb, cube_labels, geometry)
    assert evidence_problem(seen, len(cube_labels)) is None
    check = PerceptionCheck(fault_after=2.0)
    assert check.judge(seen, len(cube_labels), 1.0).accepted and check.last_good is seen


def test_garbage_frames_are_rejected_naming_what_is_missing(task, rendered):
    case, labels, rgb, cube_labels, geometry = rendered
    for name, (bad_labels, bad_rgb) in garbage_frames(labels, rgb, cube_labels).items():
        seen = estimate(task, bad_labels, bad_rgb, cube_labels, geometry)
        problem = evidence_problem(seen, len(cube_labels))
        assert problem is not None and f'of the {case.objects} cubes seen in the grid' in problem, name


def test_a_legend_without_cubes_is_no_evidence(task, rendered):
    case, labels, rgb, cube_labels, geometry = rendered
    seen = estimate(task, labels, rgb, {}, geometry)
    assert 'names no cube' in evidence_problem(seen, 0)


def test_an_all_zero_state_is_its_own_goal_without_the_check(model):
    # Why the check exists: the leader's round reads an empty table as the goal.
    end = LeaderRound(model, 'sgcm', FSEPlanner(model)).observe(np.zeros(model.dim, dtype=np.int64))
    assert end.ending is Ending.GOAL and end.rounds == 0


class Port:
    def __init__(self):
        self.ends = []

    def execute(self, turn):
        pass

    def announce(self, turn, succeeded):
        pass

    def finish(self, end):
        self.ends.append(end)


def observe_like_the_node(rounds, check, model, seen, expected, stamp):
    """What leader_planner._observe does with an estimate: judge it, then use it or report the fault."""
    verdict = check.judge(seen, expected, stamp)
    if verdict.accepted:
        return rounds.table_seen(model.state_of(seen.counts))
    if verdict.fault:
        last = check.last_good
        return rounds.perception_fault(verdict.reason, model.state_of(last.counts) if last else
                                       np.zeros(model.dim, dtype=np.int64))
    return None


@pytest.mark.parametrize('frame', ['empty 0x0', 'no cube visible', 'all unknown labels', 'truncated',
                                   'cut through the cubes'])
def test_garbage_frames_never_yield_goal_reached_and_end_in_a_perception_fault(task, model, rendered, frame):
    case, labels, rgb, cube_labels, geometry = rendered
    bad_labels, bad_rgb = garbage_frames(labels, rgb, cube_labels)[frame]
    seen = estimate(task, bad_labels, bad_rgb, cube_labels, geometry)
    port = Port()
    rounds = LeaderRounds(LeaderRound(model, 'sgcm', FSEPlanner(model)), port)
    check = PerceptionCheck(fault_after=3.0)
    for stamp in np.arange(10.0, 12.9, 0.5):                 # rejected, looking again every 0.5 s
        assert observe_like_the_node(rounds, check, model, seen, len(cube_labels), stamp) is None
    assert rounds.phase is LeaderPhase.OBSERVING and not port.ends and check.rejected == 6
    end = observe_like_the_node(rounds, check, model, seen, len(cube_labels), 13.0)   # 3 s of rejections
    assert end.ending is Ending.PERCEPTION_FAULT and not end.complete and end.rounds == 0
    assert end.reason.startswith('perception fault: ') and rounds.phase is LeaderPhase.DONE
    assert [e.ending for e in port.ends] == [Ending.PERCEPTION_FAULT]


def test_a_good_frame_between_rejections_keeps_the_task_going(task, model, rendered):
    case, labels, rgb, cube_labels, geometry = rendered
    good = estimate(task, labels, rgb, cube_labels, geometry)
    bad = estimate(task, np.full_like(labels, 999), rgb, cube_labels, geometry)
    port = Port()
    rounds = LeaderRounds(LeaderRound(model, 'sgcm', FSEPlanner(model), round_limit=1), port)
    check = PerceptionCheck(fault_after=3.0)
    assert observe_like_the_node(rounds, check, model, bad, len(cube_labels), 1.0) is None
    assert observe_like_the_node(rounds, check, model, bad, len(cube_labels), 3.5) is None
    turn = observe_like_the_node(rounds, check, model, good, len(cube_labels), 3.9)
    assert turn.round == 1 and np.array_equal(turn.state, model.state_of(case))
    # The rejections started over: a new bad run gets its full time again.
    verdict = check.judge(bad, len(cube_labels), 5.0)
    assert not verdict.accepted and not verdict.fault and verdict.rejected_for == 0.0 and verdict.retry_at == 5.5
    assert check.last_good is good


def test_the_fault_bound_must_be_positive():
    with pytest.raises(ValueError, match='perception_fault_after'):
        PerceptionCheck(fault_after=0.0)


def test_a_truncated_image_message_is_refused_before_perception():
    msg = Image(height=4, width=4, encoding='16UC1', step=8, data=bytes(20))    # 32 bytes announced
    with pytest.raises(ValueError, match='does not match'):
        image_array(msg)
    empty = image_array(Image(height=0, width=0, encoding='16UC1', step=0, data=b''))
    assert empty.shape == (0, 0)
    assert evidence_problem(StateEstimate(np.zeros((9, 3), dtype=np.int64), []), 9) is not None

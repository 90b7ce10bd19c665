"""State estimation from rendered top-view frames of the cases' tabletop scenes."""
from pathlib import Path

import numpy as np
import pytest

from pybullet_bridge.core import Scene, parse_scenario
from sgcm.core.perception import classify_colour, estimate_state
from sgcm.core.scenario_builder import build_scenario


def render_case(task, case):
    with Scene(parse_scenario(build_scenario(task, case), Path('.'))) as scene:
        frame = scene.render()
        cube_labels = {label: name for label, name, kind in scene.label_legend() if kind == 'cube'}
        return frame, cube_labels, scene.camera.geometry


@pytest.mark.parametrize('index', [0, 2, 4])
def test_counts_per_cell_and_colour_match_the_case(task, cases, index):
    case = cases[index]
    frame, cube_labels, geometry = render_case(task, case)
    ws = task.workspace
    estimate = estimate_state(frame.labels, frame.rgb, cube_labels, geometry, task,
                              top_height=ws.table_height + ws.cube_size)
    assert np.array_equal(estimate.counts, case.counts)
    assert len(estimate.objects) == case.objects and not estimate.off_grid


def test_a_cube_left_out_of_the_legend_is_not_counted(task, cases):
    case = cases[0]
    frame, cube_labels, geometry = render_case(task, case)
    dropped = sorted(cube_labels)[0]
    del cube_labels[dropped]
    ws = task.workspace
    estimate = estimate_state(frame.labels, frame.rgb, cube_labels, geometry, task,
                              top_height=ws.table_height + ws.cube_size)
    assert estimate.counts.sum() == case.objects - 1


def test_colour_classification_ignores_shading():
    palette = np.array([[255, 0, 0], [0, 200, 0], [0, 0, 255]], dtype=float)
    assert classify_colour(np.array([90.0, 10.0, 12.0]), palette) == 0     # a dark red
    assert classify_colour(np.array([20.0, 120.0, 25.0]), palette) == 1


def test_mismatched_images_are_rejected(task):
    with pytest.raises(ValueError, match='HxW'):
        estimate_state(np.zeros((4, 4)), np.zeros((5, 4, 3)), {}, None, task, top_height=0.0)

"""Arms: the ``arms`` section, their reach, and pick-and-place in a real Scene."""
import copy
import dataclasses
import math
import re

import numpy as np
import pybullet as p
import pytest
import yaml

from bridge_core_helpers import SCENARIO_DIR
from pybullet_bridge.core.arm import Outcome
from pybullet_bridge.core.arm.kinematics import ArmKinematics, model_path, top_down_orientation
from pybullet_bridge.core.arm.models import ARM_MODELS
from pybullet_bridge.core.errors import ScenarioError
from pybullet_bridge.core.placement import region_to_pixels
from pybullet_bridge.core.scenario import parse_scenario
from pybullet_bridge.core.scene import Scene

TABLETOP = yaml.safe_load((SCENARIO_DIR / 'test_tabletop.yaml').read_text())
TABLE_TOP = 0.4
CELL_1_0 = (-0.15, -0.05, -0.05, 0.05)   # cell (row 1, col 0): empty, next to the Panda
CELL_2_2 = (0.05, -0.15, 0.15, -0.05)    # cell (row 2, col 2): empty, next to the KUKA
MAX_TASK_TIME = 20.0                      # s of simulated time; a task takes 6-9 s


def tabletop(**arm_overrides) -> dict:
    """The test_tabletop scenario, with fields of the first arm replaced."""
    data = copy.deepcopy(TABLETOP)
    data['camera'].update(width=160, height=160)   # half the file's resolution: faster renders
    data['arms'][0].update(arm_overrides)
    return data


def parse(data):
    return parse_scenario(data, SCENARIO_DIR)


@pytest.fixture
def scene():
    with Scene(parse(tabletop())) as created:
        yield created


@pytest.fixture(scope='module')
def untouched_scene():
    """One scene shared by tests that only read it (rejected requests move nothing)."""
    with Scene(parse(tabletop())) as created:
        yield created


def pose(scene, name):
    position, orientation = p.getBasePositionAndOrientation(scene.entity(name).body_ids[0],
                                                            physicsClientId=scene.client)
    return np.array(position), orientation


def run(scene, task, cancel_in_phase=None, arm=None, limit=MAX_TASK_TIME):
    """Step until the task is done; return the phases it went through."""
    phases = []
    start = scene.sim_time
    while not task.done:
        assert scene.sim_time - start < limit, f'task still running in phase {task.phase}'
        scene.step(2)
        if not phases or phases[-1] != task.phase:
            phases.append(task.phase)
        if cancel_in_phase == task.phase and not phases.count('canceled'):
            scene.step(12)
            assert arm.cancel('canceled by the test')
            phases.append('canceled')
    return phases


# -- the section ----------------------------------------------------------------------

def test_arms_parse_with_defaults_and_derived_seeds():
    scenario = parse(tabletop())
    leader, follower = scenario.sections['arms']
    assert (leader.model.name, leader.base, leader.base_height) == ('panda', (-0.565, 0.0, 0.0), 0.4)
    assert leader.failure_probability == 0.1 and leader.home == ARM_MODELS['panda'].home
    assert leader.limits.max_tool_speed == 0.4 and leader.placement_clearance == 0.01
    # No seed given: derived from the scenario seed and the arm's index, distinct and reproducible.
    again = parse(tabletop()).sections['arms']
    assert (leader.seed, follower.seed) == (again[0].seed, again[1].seed)
    assert leader.seed != follower.seed
    other = copy.deepcopy(TABLETOP)
    other['seed'] = 8
    assert parse(other).sections['arms'][0].seed != leader.seed
    assert parse(tabletop(seed=123)).sections['arms'][0].seed == 123


@pytest.mark.parametrize('overrides, message', [
    ({'model': 'ur5'}, r"^arms\[0\]\.model: unknown arm model 'ur5' \(known: panda, kuka_iiwa, xarm6\)"),
    ({'failure_probability': 1.5}, r'^arms\[0\]\.failure_probability: must be <= 1\.0 \(got 1\.5\)'),
    ({'failure_probability': -0.1}, r'^arms\[0\]\.failure_probability: must be >= 0\.0'),
    ({'base': [0.0, 0.0]}, r'^arms\[0\]\.base: must be a list of 3 numbers'),
    ({'base': [-0.2, 0.0, 0.0]}, r"^arms\[0\]\.base: the panda pedestal .* stands inside table 'table'"),
    ({'base': [-0.95, 0.0, 0.0]}, r'^arms\[0\]\.base: arm base .* must lie inside world\.bounds'),
    ({'home': [0.0] * 6}, r'^arms\[0\]\.home: must be a list of 7 numbers'),
    ({'home': [0.0, 0.0, 0.0, 0.5, 0.0, 0.0, 0.0]}, r'^arms\[0\]\.home\[3\]: must be <= 0\.0'),
    ({'max_tool_speed': 0}, r'^arms\[0\]\.max_tool_speed: must be > 0\.0'),
    ({'seed': 1.5}, r'^arms\[0\]\.seed: must be an integer'),
    ({'name': 'follower_arm'}, r"^arms\[1\]\.name: duplicate name 'follower_arm' \(also used by arms\[0\]\)"),
    ({'name': 'red_1'}, r"^arms\[0\]\.name: duplicate name 'red_1' \(also used by cubes\[0\]\)"),
    ({'gripper': 'suction'}, r'^arms\[0\]\.gripper: unknown field'),
])
def test_invalid_arm_names_the_field(overrides, message):
    with pytest.raises(ScenarioError, match=message):
        parse(tabletop(**overrides))


@pytest.mark.parametrize('model', list(ARM_MODELS))
def test_catalogue_matches_urdf_and_reach_is_reachable(model):
    """The joint limits are the URDF's, and top-down poses at the edges of the documented reach solve."""
    spec = ARM_MODELS[model]
    client = p.connect(p.DIRECT)
    try:
        body = p.loadURDF(model_path(spec), useFixedBase=True, physicsClientId=client)
        kinematics = ArmKinematics(spec, body, client)
        for index, (low, high) in zip(kinematics.arm_indices, spec.joint_limits):
            info = p.getJointInfo(body, index, physicsClientId=client)
            assert (info[8], info[9]) == pytest.approx((low, high), abs=1e-3)
        assert len(spec.home) == len(spec.ready) == len(spec.arm_joints)
        low_z, high_z = spec.reach_height
        for distance in spec.reach:
            for height in (low_z, high_z, high_z + 0.10):   # grasp/place poses and travel poses above
                for azimuth in (-0.8, 0.8):
                    target = [distance * math.cos(azimuth), distance * math.sin(azimuth), height]
                    _, error = kinematics.solve_ik(target, top_down_orientation(azimuth + math.pi / 4),
                                                   start=spec.home)
                    assert error < 0.005, f'{model} misses {target} by {error * 1000:.1f} mm'
    finally:
        p.disconnect(client)


# -- pick and place in a scene ----------------------------------------------------------------

def test_panda_moves_a_cube_to_another_cell(scene):
    arm = scene.entity('leader_arm')
    arm.failure_probability = 0.0
    others = {name: pose(scene, name)[0] for name in ('green_1', 'blue_1', 'red_2', 'blue_2', 'green_2')}
    task = arm.start_pick_and_place(scene, 'red_1', CELL_1_0)
    assert not task.done, task.message
    phases = run(scene, task)
    assert phases == ['approach', 'grasp', 'lift', 'transport', 'place', 'release', 'retreat']
    assert task.outcome == Outcome.PLACED and task.progress == 1.0, task.message
    scene.step(120)
    position, orientation = pose(scene, 'red_1')
    xmin, ymin, xmax, ymax = CELL_1_0
    half = 0.015
    # The whole cube is inside the target cell, on the table, upright.
    assert xmin + half <= position[0] <= xmax - half and ymin + half <= position[1] <= ymax - half
    assert position[2] == pytest.approx(TABLE_TOP + half, abs=2e-3)
    up = np.array(p.getMatrixFromQuaternion(orientation)).reshape(3, 3)[:, 2]
    assert up[2] > math.cos(math.radians(5))
    assert np.allclose(task.placed_position, position, atol=2e-3)
    assert np.allclose(task.target_position, position[:2], atol=5e-3)
    for name, before in others.items():
        assert np.linalg.norm(pose(scene, name)[0] - before) < 1e-3, f'{name} was disturbed'
    # The arm is back home.
    assert np.allclose(arm.kinematics.arm_positions(), arm.home, atol=0.03)


def test_kuka_moves_a_cube_next_to_another_one(scene):
    """The pixel test puts the cube beside the one already in the cell, with the clearance."""
    arm = scene.entity('follower_arm')
    arm.failure_probability = 0.0
    resident = pose(scene, 'blue_2')[0]   # cell (1, 1) holds red_2 and blue_2 in its top row
    task = arm.start_pick_and_place(scene, 'blue_1', (-0.05, -0.05, 0.05, 0.05))
    run(scene, task)
    assert task.outcome == Outcome.PLACED, task.message
    position = pose(scene, 'blue_1')[0]
    assert -0.035 <= position[0] <= 0.035 and -0.035 <= position[1] <= 0.035
    for name in ('red_2', 'blue_2'):
        other = pose(scene, name)[0]
        gap = max(abs(position[0] - other[0]), abs(position[1] - other[1])) - 0.03
        assert gap >= arm.placement_clearance - 2e-3, f'{gap:.4f} m from {name}'
    assert np.linalg.norm(pose(scene, 'blue_2')[0] - resident) < 1e-3


def test_failure_probability_one_leaves_the_cube_in_place(scene):
    arm = scene.entity('leader_arm')
    arm.failure_probability = 1.0
    before = pose(scene, 'red_1')[0]
    task = arm.start_pick_and_place(scene, 'red_1', CELL_1_0)
    assert task.slipped
    phases = run(scene, task)
    assert phases[-1] == 'retreat' and 'transport' in phases   # the motion is made, empty-handed
    assert task.outcome == Outcome.EXECUTION_FAILED and 'slipped' in task.message
    assert np.linalg.norm(pose(scene, 'red_1')[0] - before) < 1e-3


def test_failure_draws_are_reproducible_per_seed():
    data = tabletop(failure_probability=0.5, seed=5)
    data['arms'][1].update(failure_probability=0.5, seed=6)

    def draws(scene, arm_name, object_name, region):
        arm = scene.entity(arm_name)
        outcomes = []
        for _ in range(6):
            outcomes.append(arm.start_pick_and_place(scene, object_name, region).slipped)
            arm.abort('test: draw only')
        return outcomes

    with Scene(parse(data)) as scene:
        first = draws(scene, 'leader_arm', 'red_1', CELL_1_0)
        scene.reset()   # re-seeds: the same sequence again
        assert draws(scene, 'leader_arm', 'red_1', CELL_1_0) == first
        assert 0 < sum(first) < 6
        assert draws(scene, 'follower_arm', 'red_2', CELL_2_2) != first   # another seed, another sequence


def test_arm_at_home_does_not_hide_the_table(untouched_scene):
    scene = untouched_scene
    legend = {name: label for label, name, _ in scene.label_legend()}
    labels = scene.render().labels
    table = scene.entity('table')
    u0, v0, u1, v1 = region_to_pixels(scene.camera, table.top_rect, TABLE_TOP)
    over_table = labels[v0:v1 + 1, u0:u1 + 1]
    assert over_table.size > 0.5 * labels.size   # the table fills most of the image
    for arm in ('leader_arm', 'follower_arm'):
        assert not np.any(over_table == legend[arm]), f'{arm} covers the table at home'
    assert np.isin(over_table, [legend['table']] + [legend[c] for c in legend if c.split('_')[0]
                                                    in ('red', 'green', 'blue')]).all()


@pytest.mark.parametrize('object_name, region, message', [
    ('nope', CELL_1_0, r"^unknown object 'nope' \(cubes in the scene: red_1, green_1"),
    ('table', CELL_1_0, r"^'table' is a table, not a cube"),
    ('red_1', (0.0, 0.0, 0.0, 0.1), r'^place_region \[0\.0, 0\.0, 0\.0, 0\.1\] is empty'),
    ('red_1', (0.0, 0.0, math.nan, 0.1), r'^place_region\[2\]: must be finite'),
    ('red_1', (0.0, 0.1), r'^place_region: must be a list of 4 numbers'),
    ('red_1', (0.6, -0.05, 0.7, 0.05), r"^place_region corner at \(0\.600, -0\.050\) is 1\.16\d m from the "
                                       r"base of arm 'leader_arm' \(panda reach 0\.27\.\.0\.74 m\); out of reach"),
    ('red_1', (-0.1, -0.1, -0.06, -0.06), r"^place_region .* is smaller than the footprint of 'red_1'"),
])
def test_bad_requests_are_rejected_with_a_reason(untouched_scene, object_name, region, message):
    arm = untouched_scene.entity('leader_arm')
    task = arm.start_pick_and_place(untouched_scene, object_name, region)
    assert task.outcome == Outcome.REJECTED
    assert task.progress == 0.0
    assert re.search(message, task.message), task.message
    assert not arm.busy


def test_object_out_of_reach_and_busy_arm_are_rejected(scene):
    far = copy.deepcopy(TABLETOP)
    far['cubes'].append({'name': 'far_cube', 'position': [0.5, 0.6], 'color': [1, 1, 0]})
    with Scene(parse(far)) as other:
        task = other.entity('leader_arm').start_pick_and_place(other, 'far_cube', CELL_1_0)
        assert task.outcome == Outcome.REJECTED
        assert "object 'far_cube' at (0.500, 0.600)" in task.message and 'out of reach' in task.message
    arm = scene.entity('leader_arm')
    first = arm.start_pick_and_place(scene, 'red_1', CELL_1_0)
    second = arm.start_pick_and_place(scene, 'green_1', CELL_1_0)
    assert not first.done and second.outcome == Outcome.REJECTED
    assert "busy moving 'red_1'" in second.message


def test_full_cell_has_no_free_spot(scene):
    # Cell (0, 0) holds red_1 and green_1 in its top row; with a 0.06 m clearance no third fits.
    arm = scene.entity('follower_arm')
    arm.placement_clearance = 0.03
    task = arm.start_pick_and_place(scene, 'red_2', (-0.15, 0.05, -0.05, 0.15))
    assert task.outcome == Outcome.NO_FREE_SPOT and 'no free spot' in task.message
    assert not arm.busy


def test_cancel_while_holding_puts_the_cube_back(scene):
    arm = scene.entity('leader_arm')
    arm.failure_probability = 0.0
    before = pose(scene, 'red_1')[0]
    task = arm.start_pick_and_place(scene, 'red_1', CELL_1_0)
    phases = run(scene, task, cancel_in_phase='transport', arm=arm)
    # Carried back over the pick spot, set down there, then home.
    assert phases == ['approach', 'grasp', 'lift', 'transport', 'canceled', 'transport', 'place', 'release',
                      'retreat']
    assert task.outcome == Outcome.ABORTED and 'put back' in task.message
    after = pose(scene, 'red_1')[0]
    assert np.linalg.norm(after[:2] - before[:2]) < 3e-3 and after[2] == pytest.approx(before[2], abs=2e-3)
    assert not arm.cancel()   # nothing left to cancel


def test_cancel_before_the_grasp_goes_home(scene):
    arm = scene.entity('leader_arm')
    task = arm.start_pick_and_place(scene, 'red_1', CELL_1_0)
    phases = run(scene, task, cancel_in_phase='approach', arm=arm)
    assert phases == ['approach', 'canceled', 'retreat']
    assert task.outcome == Outcome.ABORTED and 'not grasped' in task.message
    assert np.allclose(arm.kinematics.arm_positions(), arm.home, atol=0.03)


def test_stuck_motion_fails_with_the_phase_named(scene):
    arm = scene.entity('leader_arm')
    # Motors too weak to hold the arm up: the approach cannot converge.
    arm.model = dataclasses.replace(arm.model, joint_max_force=(0.5,) * 7)
    arm.limits = dataclasses.replace(arm.limits, phase_timeout=0.5)
    task = arm.start_pick_and_place(scene, 'red_1', CELL_1_0)
    run(scene, task)
    assert task.outcome == Outcome.EXECUTION_FAILED
    assert task.message.startswith("phase 'approach' (move above the object) did not finish within")
    assert 'simulated time' in task.message


def test_scene_reset_aborts_a_running_task(scene):
    arm = scene.entity('leader_arm')
    task = arm.start_pick_and_place(scene, 'red_1', CELL_1_0)
    scene.step(240)
    assert not task.done
    scene.reset()
    assert task.outcome == Outcome.ABORTED and 'reset' in task.message
    assert not arm.busy
    again = arm.start_pick_and_place(scene, 'red_1', CELL_1_0)
    assert not again.done, again.message

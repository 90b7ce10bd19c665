"""Environment: map files, orientation, per-robot-type inflation and configuration-space SDF."""
import cv2
import numpy as np
import pytest
import yaml

from role_engine.core.environment import Environment, RobotType, load_map_file
from role_engine.core.errors import RoleEngineError

from roles_map_helpers import MAPS_DIR, RESOLUTION, cell_centre, empty_grid, environment

GOOD_MAP = {'image': 'm.png', 'resolution': 0.05, 'origin': [-1.0, -0.5]}


def write_map(tmp_path, fields: dict, image: np.ndarray | None = None):
    if image is None:
        image = np.full((20, 30), 255, dtype=np.uint8)
        image[0:5, 0:10] = 0            # top-left block: large y, small x
    cv2.imwrite(str(tmp_path / 'm.png'), image)
    path = tmp_path / 'm.yaml'
    path.write_text(yaml.safe_dump(fields))
    return path


def test_map_file_is_read_y_up(tmp_path):
    env = load_map_file(write_map(tmp_path, GOOD_MAP))
    assert env.shape == (20, 30) and env.resolution == 0.05 and env.origin == (-1.0, -0.5)
    assert env.name == 'm' and env.border_is_obstacle
    # Image row 0 is the top of the map: the block lies at large y.
    assert env.occupied[15:20, 0:10].all() and env.occupied.sum() == 50
    x, y = -1.0 + 0.1, -0.5 + 0.95     # inside the block
    assert env.sdf.distance(np.array([[x, y]]))[0] < 0
    assert np.array_equal(env.image() == 0, cv2.imread(str(tmp_path / 'm.png'), cv2.IMREAD_GRAYSCALE) == 0)


@pytest.mark.parametrize('change, message', [
    ({'resolution': -0.1}, r'm.yaml.resolution: must be > 0'),
    ({'resolution': None}, r'm.yaml.resolution: missing required field'),
    ({'origin': [1.0]}, r'm.yaml.origin: must be a list of 2 numbers'),
    ({'occupied_below': 300}, r'm.yaml.occupied_below: must be <= 256'),
    ({'border_is_obstacle': 'maybe'}, r'm.yaml.border_is_obstacle: must be true or false'),
    ({'colour': 3}, r'm.yaml.colour: unknown field'),
    ({'image': 'missing.png'}, r'm.yaml.image: image file .* does not exist'),
])
def test_bad_map_files_name_the_field(tmp_path, change, message):
    fields = {**GOOD_MAP, **change}
    fields = {k: v for k, v in fields.items() if v is not None}
    with pytest.raises(ValueError, match=message):
        load_map_file(write_map(tmp_path, fields))


def test_unreadable_image_and_missing_file_are_clear_errors(tmp_path):
    path = write_map(tmp_path, GOOD_MAP)
    (tmp_path / 'm.png').write_text('not an image')
    with pytest.raises(ValueError, match='m.png.: not a PNG'):
        load_map_file(path)
    with pytest.raises(ValueError, match='does not exist'):
        load_map_file(tmp_path / 'nope.yaml')
    (tmp_path / 'bad.yaml').write_text('image: [unclosed\n')
    with pytest.raises(ValueError, match="map file '.*bad.yaml': invalid YAML"):
        load_map_file(tmp_path / 'bad.yaml')
    (tmp_path / 'empty.yaml').write_text('')
    with pytest.raises(ValueError, match='file is empty'):
        load_map_file(tmp_path / 'empty.yaml')


@pytest.mark.parametrize('index', range(1, 7))
def test_shipped_environments_load(index):
    env = load_map_file(MAPS_DIR / f'env_{index}.yaml')
    assert env.shape == (200, 200) and env.resolution == 0.025 and env.origin == (-2.5, -2.5)
    assert 0.03 < env.occupied.mean() < 0.5


def test_inflation_grows_with_the_radius():
    grid = empty_grid()
    grid[20, 20] = True
    env = environment(grid, border_is_obstacle=False)
    point = env.for_robot(RobotType('point', 0.0))
    small = env.for_robot(RobotType('small', 0.1))
    large = env.for_robot(RobotType('large', 0.2, inflation_margin=0.05))
    assert np.array_equal(point.inflated, grid)
    assert (small.inflated >= point.inflated).all() and (large.inflated >= small.inflated).all()
    # A cell whose centre is 2 cells (0.1 m) right of the obstacle cell's centre is 0.075 m from its
    # surface: inside the small robot's inflation (0.1 m), outside a 0.05 m robot's.
    assert small.inflated[20, 22] and not env.for_robot(RobotType('tiny', 0.05)).inflated[20, 22]
    assert large.inflated[20, 24] and not large.inflated[20, 26]
    assert small.is_visitable(cell_centre(20, 30)) and not small.is_visitable(cell_centre(20, 21))
    assert not small.is_visitable((-1.0, 0.5))   # off the map


def test_robot_sdf_is_the_body_clearance():
    grid = empty_grid()
    grid[:, :5] = True
    env = environment(grid)
    robot = env.for_robot(RobotType('r', 0.2))
    points = np.array([cell_centre(20, ix) for ix in range(12, 30)])
    workspace = env.sdf.distance(points)
    body = robot.sdf.distance(points)
    # Far from the arena border the robot's SDF is the workspace distance minus the radius.
    assert body[:8] == pytest.approx(workspace[:8] - 0.2, abs=RESOLUTION)
    assert robot.components.max() == 1


def test_bad_grids_and_robot_types_are_rejected():
    with pytest.raises(RoleEngineError, match='boolean'):
        Environment(np.zeros((3, 3)), 0.1, (0, 0))
    with pytest.raises(RoleEngineError, match='2-D'):
        Environment(np.zeros(3, dtype=bool), 0.1, (0, 0))
    with pytest.raises(RoleEngineError, match='resolution'):
        Environment(np.zeros((3, 3), dtype=bool), -1.0, (0, 0))
    with pytest.raises(RoleEngineError, match=r"robot_type 'r'.radius: must be a finite number >= 0"):
        RobotType('r', -0.1)
    with pytest.raises(RoleEngineError, match='max_linear_velocity'):
        RobotType('r', 0.1, max_linear_velocity=0.0)

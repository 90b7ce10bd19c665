"""Nav2 map YAMLs: the pure reader (pybullet_bridge.core.occupancy_map.read_nav2_map) as the role engine
and the bridge's obstacles section use it -- origin with yaw, negate, thresholds, bad fields refused --
and the narrow-corridor map shipped under config/maps/."""
import math
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

from pybullet_bridge.core.errors import ScenarioError
from pybullet_bridge.core.obstacles import parse_obstacles
from pybullet_bridge.core.occupancy_map import FREE, OCCUPIED, UNKNOWN, read_nav2_map
from pybullet_bridge.core.sections import SectionContext
from role_engine.core.environment import RobotType, load_map_file
from role_engine.core.errors import RoleEngineError

from roles_map_helpers import MAPS_DIR

WS = Path(__file__).resolve().parents[3]
CORRIDOR_MAP = WS / 'config' / 'maps' / 'pillar_corridors.yaml'
NAV2 = {'image': 'm.png', 'resolution': 0.1, 'origin': [1.0, 2.0, 0.0], 'negate': 0, 'occupied_thresh': 0.65,
        'free_thresh': 0.25}


def grey_ramp() -> np.ndarray:
    """4 rows x 5 columns; row 0 (the top): black, dark grey (p = 0.61), mid grey (p = 0.4), light (p = 0.2),
    white; the other rows white except a black pixel at the bottom-left corner."""
    image = np.full((4, 5), 255, dtype=np.uint8)
    image[0] = [0, 100, 153, 204, 255]
    image[3, 0] = 0
    return image


def write(tmp_path, fields: dict, image: np.ndarray | None = None, name: str = 'm') -> Path:
    cv2.imwrite(str(tmp_path / 'm.png'), grey_ramp() if image is None else image)
    path = tmp_path / f'{name}.yaml'
    path.write_text(yaml.safe_dump(fields))
    return path


def test_thresholds_and_negate(tmp_path):
    cells = read_nav2_map(write(tmp_path, NAV2)).cells
    # p = (255 - shade) / 255: 1.0, 0.61, 0.4, 0.2, 0 -> occupied, unknown, unknown, free, free
    assert cells[0].tolist() == [OCCUPIED, UNKNOWN, UNKNOWN, FREE, FREE]
    lower = read_nav2_map(write(tmp_path, dict(NAV2, occupied_thresh=0.5, free_thresh=0.3))).cells
    assert lower[0].tolist() == [OCCUPIED, OCCUPIED, UNKNOWN, FREE, FREE]
    negated = read_nav2_map(write(tmp_path, dict(NAV2, negate=1))).cells
    # p = shade / 255: 0, 0.39, 0.6, 0.8, 1.0 -> free, unknown, unknown, occupied, occupied
    assert negated[0].tolist() == [FREE, UNKNOWN, UNKNOWN, OCCUPIED, OCCUPIED]
    assert negated[1].tolist() == [OCCUPIED] * 5          # white rows are walls when negated


def test_role_engine_environment_unknown_is_an_obstacle_and_rows_are_y_up(tmp_path):
    env = load_map_file(write(tmp_path, dict(NAV2, name='ramp', border_is_obstacle=False)))
    assert env.name == 'ramp' and not env.border_is_obstacle
    assert env.shape == (4, 5) and env.origin == (1.0, 2.0) and env.resolution == 0.1
    # Image row 0 (top) is grid row 3 (largest y); the unknown greys count as obstacles.
    assert env.occupied[3].tolist() == [True, True, True, False, False]
    assert env.occupied[0].tolist() == [True, False, False, False, False]


def test_origin_yaw_rotates_the_map_about_its_bottom_left_corner(tmp_path):
    image = np.full((4, 5), 255, dtype=np.uint8)
    image[3, 0] = 0        # the bottom-left pixel: map frame [0, 0.1] x [0, 0.1]
    image[3, 4] = 0        # the bottom-right pixel: map frame [0.4, 0.5] x [0, 0.1]
    path = write(tmp_path, dict(NAV2, origin=[1.0, 2.0, math.pi / 2]), image)
    nav2 = read_nav2_map(path)
    # Rotated by 90 degrees: map +x is world +y. Box of the bottom-right pixel: centre map (0.45, 0.05)
    # -> world (1.0 - 0.05, 2.0 + 0.45).
    boxes = sorted(nav2.boxes(), key=lambda b: b[0][1])
    assert len(boxes) == 2
    np.testing.assert_allclose(boxes[0][0], (0.95, 2.05), atol=1e-9)
    np.testing.assert_allclose(boxes[1][0], (0.95, 2.45), atol=1e-9)
    assert boxes[1][2] == pytest.approx(math.pi / 2)
    env = load_map_file(path)
    # The axis-aligned grid covers world x in [0.6, 1.0], y in [2.0, 2.5] (4 x 5 cells of 0.1 m).
    assert env.origin == pytest.approx((0.6, 2.0)) and env.shape == (5, 4)
    inside = env.sdf.distance(np.array([[0.95, 2.05], [0.95, 2.45], [0.75, 2.25]]))
    assert inside[0] < 0 and inside[1] < 0 and inside[2] > 0


@pytest.mark.parametrize('change, message', [
    ({'negate': None}, r'm\.yaml\.negate: missing required field'),
    ({'negate': 2}, r'm\.yaml\.negate: must be 0 or 1'),
    ({'origin': [1.0, 2.0]}, r'm\.yaml\.origin: must be a list of 3 numbers'),
    ({'origin': [1.0, 2.0, 'north']}, r'm\.yaml\.origin'),
    ({'occupied_thresh': 1.5}, r'm\.yaml\.occupied_thresh: must be <= 1'),
    ({'free_thresh': 0.7}, r'm\.yaml\.free_thresh: must be <= occupied_thresh 0.65'),
    ({'mode': 'scale'}, r'm\.yaml\.mode: must be trinary'),
    ({'resolution': 0.0}, r'm\.yaml\.resolution: must be > 0'),
    ({'image': 'missing.png'}, r"m\.yaml\.image: image file .*missing\.png': does not exist"),
    ({'colour': 'red'}, r'm\.yaml.*colour'),
])
def test_bad_fields_are_refused_naming_them(tmp_path, change, message):
    fields = {k: v for k, v in dict(NAV2, **change).items() if v is not None}
    path = write(tmp_path, fields)
    with pytest.raises(RoleEngineError, match=message):
        load_map_file(path)
    with pytest.raises(ScenarioError, match=message):
        read_nav2_map(path)


def test_a_missing_required_field_is_named(tmp_path):
    fields = dict(NAV2)
    del fields['occupied_thresh']
    with pytest.raises(RoleEngineError, match=r'm\.yaml\.occupied_thresh: missing required field'):
        load_map_file(write(tmp_path, fields))


def test_the_shipped_role_maps_are_nav2_maps_and_read_as_before(tmp_path):
    """env_1..6 moved to the Nav2 form; the legacy form of the same file gives the very same grid."""
    for index in range(1, 7):
        data = yaml.safe_load((MAPS_DIR / f'env_{index}.yaml').read_text())
        assert {'negate', 'occupied_thresh', 'free_thresh'} <= set(data) and len(data['origin']) == 3
        legacy = {k: v for k, v in data.items() if k not in ('negate', 'occupied_thresh', 'free_thresh', 'mode')}
        legacy.update(image=str(MAPS_DIR / data['image']), origin=data['origin'][:2], occupied_below=128)
        (tmp_path / f'legacy_{index}.yaml').write_text(yaml.safe_dump(legacy))
        old, new = load_map_file(tmp_path / f'legacy_{index}.yaml'), load_map_file(MAPS_DIR / f'env_{index}.yaml')
        assert np.array_equal(old.occupied, new.occupied) and old.origin == new.origin
        assert new.name == f'env_{index}'


def test_bridge_obstacles_section_reads_the_same_nav2_yaml(tmp_path):
    context = SectionContext(path='obstacles', base_dir=WS / 'config' / 'scenarios', world=None, robot_types={},
                             seed=None)
    boxes = parse_obstacles({'map': '../maps/pillar_corridors.yaml'}, context)
    assert len(boxes) == 16 and all(b.size == pytest.approx((0.3, 0.3)) for b in boxes)
    centres = sorted(round(v, 4) for b in boxes for v in b.center[:1])
    assert sorted(set(centres)) == [-1.3875, -0.4625, 0.4625, 1.3875]
    tall = parse_obstacles({'map': {'yaml': str(CORRIDOR_MAP), 'height': 0.5}}, context)
    assert len(tall) == 16 and tall[0].height == 0.5
    with pytest.raises(ScenarioError, match=r"obstacles\.map\.yaml: map file .* does not exist"):
        parse_obstacles({'map': 'nope.yaml'}, context)
    with pytest.raises(ScenarioError, match=r'obstacles\.map.*image'):
        parse_obstacles({'map': {'yaml': str(CORRIDOR_MAP), 'image': 'x.png'}}, context)


def test_the_narrow_corridor_map():
    """Pillars 0.3 m, corridors 0.625 m: a Pioneer (r = 0.23 m, + 0.03 m margin) fits, centred only."""
    env = load_map_file(CORRIDOR_MAP)
    assert env.resolution == 0.0125 and env.origin == (-2.5, -2.5)
    # Half a corridor from the pillars on the corridor's centre line between two pillars.
    assert env.sdf.distance(np.array([[0.0, 1.3875], [0.925, -0.4625]])) == pytest.approx([0.3125, 0.3125], abs=0.013)
    pioneer = env.for_robot(RobotType('pioneer', 0.23, inflation_margin=0.03))
    assert pioneer.is_visitable((0.0, 1.3875)) and not pioneer.is_visitable((0.1, 1.3875))
    # Every start and diamond point of the demo (config/scenarios/roles_formation.yaml, size 2.2) is free.
    for point in [(-1.8, -1.8), (1.8, -1.8), (-1.8, 1.8), (1.8, 1.8), (1.1, 0.0), (-1.1, 0.0), (0.0, 1.1),
                  (0.0, -1.1)]:
        assert pioneer.is_visitable(point), point


def test_the_map_generator_reproduces_the_shipped_files(tmp_path):
    script = WS / 'config' / 'maps' / 'make_corridor_map.py'
    copy = tmp_path / script.name
    copy.write_text(script.read_text())
    subprocess.run([sys.executable, str(copy)], check=True, capture_output=True)
    assert (tmp_path / 'pillar_corridors.yaml').read_text() == CORRIDOR_MAP.read_text()
    assert np.array_equal(cv2.imread(str(tmp_path / 'pillar_corridors.png')),
                          cv2.imread(str(CORRIDOR_MAP.with_suffix('.png'))))

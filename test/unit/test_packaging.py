"""Every package.xml declares what its code needs, as rosdep keys (`rosdep install` on apt Jazzy).

The Python packages' imports are read with ast (every import, also inside functions) and
mapped to rosdep keys: a third-party module through THIRD_PARTY_KEYS, any other non-stdlib
module is a ROS or workspace package whose key is its own name. Interface packages must
depend on every package their .msg/.srv/.action fields name.
"""
from __future__ import annotations

import ast
import re
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
import yaml

WS = Path(__file__).resolve().parents[2]
PYTHON_PACKAGES = sorted(p.parent for p in (WS / 'src').glob('*/package.xml'))
INTERFACE_PACKAGES = sorted(p.parent for p in (WS / 'interfaces').glob('*/package.xml'))

#: Python module -> rosdep key of the library that provides it.
THIRD_PARTY_KEYS = {
    'numpy': 'python3-numpy',
    'scipy': 'python3-scipy',
    'cv2': 'python3-opencv',
    'yaml': 'python3-yaml',
    'matplotlib': 'python3-matplotlib',
    'networkx': 'python3-networkx',
    'skimage': 'python3-skimage',
    'pytest': 'python3-pytest',
    'pybullet': 'python3-pybullet-pip',
    'pybullet_data': 'python3-pybullet-pip',
    'gtsam': 'python3-gtsam-pip',
    'numba': 'python3-numba-pip',
    'rosbags': 'python3-rosbags-pip',
    'tqdm': 'python3-tqdm',
    'PIL': 'python3-pil',
    'foxglove': 'python3-foxglove-sdk-pip',
    'backports': 'python3-rosbags-pip',   # backports.zstd: rosbags' own dependency below Python 3.14
    'lz4': 'python3-rosbags-pip',         # lz4.frame: rosbags' own dependency (MCAP chunk compression)
}
#: Keys found in ros/rosdistro's rosdep/python.yaml; every other key must be defined by the
#: workspace's own rosdep source (config/rosdep/*.yaml).
ROSDISTRO_KEYS = {'python3-numpy', 'python3-scipy', 'python3-opencv', 'python3-yaml', 'python3-matplotlib',
                  'python3-networkx', 'python3-skimage', 'python3-pytest', 'python3-pybullet-pip', 'python3-tqdm',
                  'python3-pil'}
#: Standard library modules newer than the interpreter running the tests (imported behind a version check).
NEWER_STDLIB = {'compression'}
DEPEND_TAGS = ('depend', 'exec_depend', 'build_export_depend')


def declared(package_dir: Path, tags=DEPEND_TAGS) -> set[str]:
    root = ET.parse(package_dir / 'package.xml').getroot()
    return {element.text.strip() for tag in tags for element in root.iter(tag)}


def imported_modules(package_dir: Path) -> dict[str, str]:
    """Top-level module -> first file importing it (absolute imports only)."""
    modules: dict[str, str] = {}
    for path in sorted((package_dir / package_dir.name).rglob('*.py')):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0:
                names = [node.module]
            else:
                continue
            for name in names:
                modules.setdefault(name.split('.')[0], str(path.relative_to(package_dir.parent)))
    return modules


def required_keys(package_dir: Path) -> dict[str, str]:
    """rosdep key -> why (the import that needs it)."""
    keys = {}
    for module, where in imported_modules(package_dir).items():
        if module in sys.stdlib_module_names or module in NEWER_STDLIB or module == package_dir.name:
            continue
        keys.setdefault(THIRD_PARTY_KEYS.get(module, module), f'import {module} in {where}')
    return keys


def workspace_rosdep_keys() -> set[str]:
    keys = set()
    for path in (WS / 'config' / 'rosdep').glob('*.yaml'):
        keys |= set(yaml.safe_load(path.read_text()))
    return keys


def test_the_packages_are_found():
    assert {p.name for p in PYTHON_PACKAGES} >= {'collab_tools', 'pybullet_bridge', 'role_engine', 'sgcm',
                                                  'coalition_agents'}
    assert {p.name for p in INTERFACE_PACKAGES} >= {'bridge_interfaces', 'tf2_msgs'}


@pytest.mark.parametrize('package_dir', PYTHON_PACKAGES, ids=lambda p: p.name)
def test_every_import_is_a_declared_dependency(package_dir):
    missing = {key: why for key, why in required_keys(package_dir).items() if key not in declared(package_dir)}
    assert not missing, (f'{package_dir.name}/package.xml lacks exec_depend for: {missing} '
                         '(a third-party module needs an entry in THIRD_PARTY_KEYS)')


@pytest.mark.parametrize('package_dir', PYTHON_PACKAGES, ids=lambda p: p.name)
def test_no_third_party_dependency_is_declared_without_use(package_dir):
    python_keys = {key for key in declared(package_dir) if key.startswith('python3-')}
    used = set(required_keys(package_dir))
    assert python_keys <= used, f'{package_dir.name}/package.xml declares unused {python_keys - used}'


def test_every_python_key_resolves_in_rosdistro_or_the_workspace_source():
    defined = workspace_rosdep_keys()
    keys = set().union(*(declared(p, DEPEND_TAGS + ('test_depend',)) for p in PYTHON_PACKAGES))
    unknown = {k for k in keys if k.startswith('python3-') and k not in ROSDISTRO_KEYS | defined}
    assert not unknown, f'no rosdep definition for {unknown}: add them to config/rosdep/'
    assert not defined & ROSDISTRO_KEYS, 'config/rosdep/ must not shadow rosdistro keys'


@pytest.mark.parametrize('package_dir', INTERFACE_PACKAGES, ids=lambda p: p.name)
def test_interface_packages_depend_on_the_packages_their_fields_name(package_dir):
    named = set()
    for path in package_dir.glob('*/*'):
        if path.suffix in ('.msg', '.srv', '.action'):
            named |= set(re.findall(r'^\s*([a-z][a-z0-9_]*)/[A-Z]\w*', path.read_text(), re.MULTILINE))
    named.discard(package_dir.name)
    assert named <= declared(package_dir), f'{package_dir.name}: undeclared {named - declared(package_dir)}'


def test_the_map_catches_an_undeclared_import(tmp_path):
    """The check itself: a package importing scipy without declaring it is reported."""
    package = tmp_path / 'demo'
    (package / 'demo').mkdir(parents=True)
    (package / 'package.xml').write_text('<package format="3"><name>demo</name>'
                                         '<exec_depend>rclpy</exec_depend></package>')
    (package / 'demo' / 'node.py').write_text('import os\nimport rclpy\n\ndef f():\n    from scipy import linalg\n')
    assert set(required_keys(package)) == {'rclpy', 'python3-scipy'}
    assert set(required_keys(package)) - declared(package) == {'python3-scipy'}

"""Every declared executable is where `ros2 run <pkg> <exe>` finds it, and cores stay rclpy-free."""

import ast
import os
import re
from pathlib import Path

import pytest

WORKSPACE = Path(__file__).resolve().parents[2]
PYTHON_PACKAGES = sorted(p.parent for p in (WORKSPACE / 'src').glob('*/setup.py'))
INTERFACE_PACKAGES = sorted(p.parent for p in (WORKSPACE / 'interfaces').glob('*/package.xml'))


def console_scripts(setup_py: Path) -> list[str]:
    """Executable names declared in setup.py's console_scripts, read without running it."""
    scripts = []
    for node in ast.walk(ast.parse(setup_py.read_text())):
        if isinstance(node, ast.Dict):
            for key, value in zip(node.keys, node.values):
                if isinstance(key, ast.Constant) and key.value == 'console_scripts':
                    scripts += [re.split(r'\s*=\s*', e.value)[0] for e in value.elts]
    return scripts


def executables():
    return [(pkg.name, exe) for pkg in PYTHON_PACKAGES for exe in console_scripts(pkg / 'setup.py')]


def test_workspace_declares_packages_and_executables():
    assert {p.name for p in PYTHON_PACKAGES} >= {'pybullet_bridge', 'collab_tools'}
    assert ('pybullet_bridge', 'pybullet_bridge') in executables()


@pytest.mark.parametrize('package, executable', executables())
def test_executable_is_where_ros2_run_looks(package, executable):
    from ament_index_python.packages import get_package_prefix, get_resource

    prefix = Path(get_package_prefix(package))
    # The ament index marker that `ros2 pkg list` / `ros2 run` rely on.
    get_resource('packages', package)
    path = prefix / 'lib' / package / executable
    assert path.is_file() and os.access(path, os.X_OK), f'{path} missing or not executable'


@pytest.mark.parametrize('package', [p.name for p in INTERFACE_PACKAGES])
def test_interface_packages_are_indexed(package):
    from ament_index_python.packages import get_resource

    content, _ = get_resource('rosidl_interfaces', package)
    assert content.strip(), f'{package} registers no interfaces'


def test_core_modules_never_import_rclpy():
    offenders = []
    for path in (WORKSPACE / 'src').glob('*/*/core/**/*.py'):
        for node in ast.walk(ast.parse(path.read_text())):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import)
                     else [node.module or ''] if isinstance(node, ast.ImportFrom) else [])
            if any(n == 'rclpy' or n.startswith('rclpy.') for n in names):
                offenders.append(str(path.relative_to(WORKSPACE)))
    assert list((WORKSPACE / 'src').glob('*/*/core/*.py')), 'no core modules found'
    assert offenders == []

"""The workspace's shape, checked the way ``test_core_modules_never_import_rclpy`` checks cores.

* no source file over 500 lines, no node module over 300;
* no import cycle among the modules of any core (late imports inside functions count);
* the algorithm cores (sgcm, role_engine, coalition_agents, collab_tools) never reach the
  simulator, directly or through another module (importing ``a.b.c`` runs ``a`` and ``a.b``'s
  ``__init__`` too); in the bridge core only the modules that simulate reach pybullet;
* OpenCV only in the modules that process images.

Imports are read with ast, also those inside functions, so a late import does not hide a cycle.
"""
from __future__ import annotations

import ast
import functools
from collections import defaultdict
from pathlib import Path

import pytest

WORKSPACE = Path(__file__).resolve().parents[2]
SOURCES = sorted(p for p in (WORKSPACE / 'src').glob('*/*/**/*.py') if '/build/' not in str(p))
MAX_LINES = 500
MAX_NODE_LINES = 300
SIMULATOR = {'pybullet', 'pybullet_data'}
IMAGE_LIBRARY = {'cv2'}
ALGORITHM_CORES = ('sgcm.core', 'role_engine.core', 'coalition_agents.core', 'collab_tools.core')

#: Bridge core modules that drive pybullet (everything else in the bridge core is parsing, geometry
#: and state machines that must stay importable without the simulator).
SIMULATING = {
    'pybullet_bridge.core.scene', 'pybullet_bridge.core.camera', 'pybullet_bridge.core.sensors',
    'pybullet_bridge.core.mobile_robot_body', 'pybullet_bridge.core.passive_bodies',
    'pybullet_bridge.core.arm.kinematics', 'pybullet_bridge.core.arm.segments', 'pybullet_bridge.core.arm.gripper',
    'pybullet_bridge.core.arm.planning', 'pybullet_bridge.core.arm.recovery', 'pybullet_bridge.core.arm.simulation',
}
#: Modules that process images with OpenCV (perception, codecs, rendering helpers).
IMAGE_PROCESSING = {
    'collab_tools.core.image_codec', 'collab_tools.core.video', 'sgcm.core.perception', 'role_engine.core.top_view',
    'role_engine.core.tracking', 'role_engine.core.occupancy', 'role_engine.core.sdf',
    'pybullet_bridge.core.occupancy_map',
}


def module_name(path: Path) -> str:
    parts = list(path.relative_to(WORKSPACE / 'src').with_suffix('').parts[1:])
    if parts[-1] == '__init__':
        parts = parts[:-1]
    return '.'.join(parts)


MODULES = {module_name(p): p for p in SOURCES}


@functools.cache
def _imported_names(path: Path, name: str) -> frozenset[str]:
    """Absolute names of everything ``path`` imports (modules, or module.attribute for from-imports)."""
    package = name if path.name == '__init__.py' else name.rpartition('.')[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base_parts = package.split('.')
                base_parts = base_parts[:len(base_parts) - (node.level - 1)]
                base = '.'.join(base_parts + ([node.module] if node.module else []))
            else:
                base = node.module or ''
            found.add(base)
            found.update(f'{base}.{alias.name}' for alias in node.names)
    return frozenset(found)


@functools.cache  # the graph is read once per run, not once per parametrized check
def _edges(with_parents: bool) -> dict[str, set[str]]:
    """Workspace module -> workspace modules and external top-level names it imports."""
    edges = defaultdict(set)
    for name, path in MODULES.items():
        for imported in _imported_names(path, name):
            if imported in MODULES:
                target = imported
            elif imported.rpartition('.')[0] in MODULES:
                target = imported.rpartition('.')[0]       # from module import attribute
            elif imported.split('.')[0] in {m.split('.')[0] for m in MODULES}:
                continue                                   # a name that is no module (e.g. a constant)
            else:
                edges[name].add('!' + imported.split('.')[0])  # an external library
                continue
            edges[name].add(target)
            if with_parents:  # importing a.b.c runs a/__init__ and a/b/__init__ first
                parts = target.split('.')
                edges[name].update('.'.join(parts[:i]) for i in range(1, len(parts)) if '.'.join(parts[:i]) in MODULES)
    return edges


def _reaches(edges: dict[str, set[str]], start: str) -> dict[str, list[str]]:
    """External libraries reachable from ``start``, each with one import chain leading to it."""
    chains = {start: [start]}
    queue = [start]
    found = {}
    while queue:
        current = queue.pop()
        for target in sorted(edges.get(current, ())):
            if target.startswith('!'):
                found.setdefault(target[1:], chains[current])
            elif target not in chains:
                chains[target] = chains[current] + [target]
                queue.append(target)
    return found


def _cycles(edges: dict[str, set[str]], prefix: str) -> list[list[str]]:
    """Strongly connected components (size > 1) among the non-__init__ modules under ``prefix``."""
    nodes = [m for m in MODULES if m.startswith(prefix + '.') and MODULES[m].name != '__init__.py']
    graph = {n: [t for t in edges.get(n, ()) if t in nodes] for n in nodes}
    index, low, stack, on_stack, result, counter = {}, {}, [], set(), [], [0]

    def visit(node):
        index[node] = low[node] = counter[0]
        counter[0] += 1
        stack.append(node)
        on_stack.add(node)
        for target in graph[node]:
            if target not in index:
                visit(target)
                low[node] = min(low[node], low[target])
            elif target in on_stack:
                low[node] = min(low[node], index[target])
        if low[node] == index[node]:
            component = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                component.append(member)
                if member == node:
                    break
            if len(component) > 1 or node in graph[node]:
                result.append(sorted(component))

    for node in nodes:
        if node not in index:
            visit(node)
    return result


CORES = sorted({m for m in MODULES if m.endswith('.core')})


@pytest.mark.parametrize('path', SOURCES, ids=lambda p: str(p.relative_to(WORKSPACE / 'src')))
def test_source_files_stay_readable(path):
    lines = len(path.read_text().splitlines())
    assert lines <= MAX_LINES, f'{path.name}: {lines} lines (at most {MAX_LINES}: split it by concern)'


def _is_node_module(path: Path) -> bool:
    if path.name.endswith('_node.py'):
        return True
    tree = ast.parse(path.read_text())
    return any(isinstance(n, ast.ClassDef) and any(getattr(b, 'id', getattr(b, 'attr', '')) == 'Node' for b in n.bases)
               for n in ast.walk(tree))


NODE_MODULES = [p for p in SOURCES if '/core/' not in str(p) and _is_node_module(p)]


@pytest.mark.parametrize('path', NODE_MODULES, ids=lambda p: str(p.relative_to(WORKSPACE / 'src')))
def test_nodes_stay_thin(path):
    lines = len(path.read_text().splitlines())
    assert lines <= MAX_NODE_LINES, (f'{path.name}: {lines} lines (a node is an adapter, at most '
                                     f'{MAX_NODE_LINES}: move behaviour into the core)')


@pytest.mark.parametrize('core', CORES)
def test_no_import_cycles_in_core(core):
    assert _cycles(_edges(with_parents=False), core) == []


@pytest.mark.parametrize('core', ALGORITHM_CORES)
def test_algorithm_cores_never_reach_the_simulator(core):
    edges = _edges(with_parents=True)
    offenders = {}
    for name in MODULES:
        if name == core or name.startswith(core + '.'):
            reached = _reaches(edges, name)
            for library in sorted(SIMULATOR & set(reached)):
                offenders[name] = ' -> '.join(reached[library] + [library])
    assert offenders == {}


def test_bridge_core_reaches_the_simulator_only_where_it_simulates():
    edges = _edges(with_parents=True)
    offenders = {}
    for name in MODULES:
        if name.startswith('pybullet_bridge.core') and name not in SIMULATING and MODULES[name].name != '__init__.py':
            reached = _reaches(edges, name)
            for library in sorted(SIMULATOR & set(reached)):
                offenders[name] = ' -> '.join(reached[library] + [library])
    assert offenders == {}


def test_opencv_only_where_images_are_processed():
    edges = _edges(with_parents=False)
    offenders = sorted(name for name in MODULES if '.core' in name and name not in IMAGE_PROCESSING
                       and any(t[1:] in IMAGE_LIBRARY for t in edges.get(name, ()) if t.startswith('!')))
    assert offenders == []


def test_the_checks_see_the_workspace():
    # Guards the checks above from passing vacuously (a path or naming change would empty them).
    assert len(MODULES) > 100 and len(CORES) >= 5 and len(NODE_MODULES) >= 8
    edges = _edges(with_parents=True)
    assert 'pybullet' in _reaches(edges, 'pybullet_bridge.core.scene')
    cycles = _cycles(_edges(with_parents=False), 'pybullet_bridge')
    assert all(len(c) > 1 for c in cycles)  # the finder reports components, not single modules


def test_test_files_have_unique_names():
    # pytest's default import mode imports test files by their base name: two test_x.py in
    # different folders stop the whole collection ("import file mismatch") on a clean checkout.
    names = defaultdict(list)
    for path in (WORKSPACE / 'test').rglob('test_*.py'):
        names[path.name].append(str(path.relative_to(WORKSPACE)))
    assert {name: paths for name, paths in names.items() if len(paths) > 1} == {}

"""Starting the role nodes in a test session: the engine in the team namespace, each player in its robot's."""

from pathlib import Path

import yaml

from collab_tools.orchestration.node_process import NodeSpec

ENGINE = '/role_engine'
TRACKER = '/robot_tracker'


def player_node(robot: str) -> str:
    """Full ROS name of a robot's role player."""
    return f'/{robot}/role_player'


def engine_spec(settings_file, **parameters) -> NodeSpec:
    return NodeSpec('role_engine', 'role_engine', name='role_engine',
                    parameters=[{'settings_file': str(settings_file), **parameters}])


def tracker_spec(**parameters) -> NodeSpec:
    """``/robot_tracker``: the robots' poses from the top camera for the players."""
    return NodeSpec('role_engine', 'robot_tracker', name='robot_tracker',
                    parameters=[dict(parameters)] if parameters else [])


def player_spec(robot: str, settings_file, required: bool = False, **parameters) -> NodeSpec:
    """``/<robot>/role_player`` (no robot parameter: the namespace says it); session label ``<robot>/role_player``."""
    return NodeSpec('role_engine', 'role_player', namespace=f'/{robot}', required=required,
                    parameters=[{'settings_file': str(settings_file), **parameters}])


def settings_without_scenario(settings_file, directory):
    """A copy of the settings file whose scenario does not exist, as on a robot with no bridge files."""
    data = yaml.safe_load(Path(settings_file).read_text())
    data['scenario'] = '/nonexistent/host/scenario.yaml'
    path = Path(directory) / 'player_settings.yaml'
    path.write_text(yaml.safe_dump(data))
    return path


def player_process(session, robot: str):
    """The session's process of ``robot``'s role player."""
    for process in session.nodes.values():
        if process.spec.executable == 'role_player' and (process.spec.namespace or '').split('/')[-1] == robot:
            return process
    raise AssertionError(f'no role player of {robot} in the session ({", ".join(session.nodes)})')

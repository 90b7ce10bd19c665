"""Console entry points of this package's nodes (setup.py): each imports its node's module with
quiet stop signals first (collab_tools.node_entry), so a Ctrl-C while it loads is a stop, not a crash."""

from collab_tools.node_entry import entry_point

role_engine = entry_point('role_engine.role_engine_node')
role_player = entry_point('role_engine.role_player_node')
robot_tracker = entry_point('role_engine.robot_tracker_node')

"""Console entry points of this package's nodes (setup.py): each imports its node's module with
quiet stop signals first (collab_tools.node_entry), so a Ctrl-C while it loads is a stop, not a crash."""

from collab_tools.node_entry import entry_point

pybullet_bridge = entry_point('pybullet_bridge.bridge_node')

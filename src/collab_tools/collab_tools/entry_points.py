"""Console entry points of this package's nodes (setup.py): each imports its node's module with
quiet stop signals first (collab_tools.node_entry), so a Ctrl-C while it loads is a stop, not a crash."""

from collab_tools.node_entry import entry_point

bag_recorder = entry_point('collab_tools.bag_recorder_node')
live_view = entry_point('collab_tools.live_view_node')
scripted_driver = entry_point('collab_tools.scripted_driver_node')
visualiser = entry_point('collab_tools.visualiser_node')

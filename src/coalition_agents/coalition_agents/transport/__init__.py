"""The coalition agents' message transport on ROS: :mod:`.agent_channel` puts the pure transport
(:mod:`coalition_agents.core.transport`) on per-robot inbox topics."""

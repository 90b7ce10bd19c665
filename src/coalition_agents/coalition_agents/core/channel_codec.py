"""Deprecated: moved to :mod:`.transport.codec` (issue 12). Kept only until the experiments stop
importing it from here; new code imports ``coalition_agents.core.transport.codec``."""
from .transport.codec import *  # noqa: F401,F403
from .transport.codec import MessageKind  # noqa: F401

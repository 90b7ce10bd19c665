"""Errors raised by the simulation core."""
from collab_tools.core.errors import ConfigurationError


class ScenarioError(ConfigurationError):
    """A scenario file or dict is invalid.

    The message starts with the dotted path of the offending field, e.g.
    ``mobile_robots[1].max_linear_velocity: must be > 0 (got -1.0)``, so a user
    can find the mistake without reading a traceback.
    """

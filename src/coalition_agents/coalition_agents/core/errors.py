"""Errors raised by the coalition core.

Every message starts with what is wrong and where (a file's dotted field path, or the
request field), so a user or a node's log names the mistake without a traceback.
"""
from collab_tools.core.errors import ConfigurationError


class CoalitionError(ConfigurationError):
    """Base class of every error the coalition core raises on bad input (a ConfigurationError,
    so a node that cannot start with it exits 2 with the message)."""


class ConfigError(CoalitionError):
    """A configuration file or dict (costs, schema library, tasks, capabilities) is invalid.

    The message starts with the dotted path of the offending field, e.g.
    ``robot_types.scout.sensors[1].provides[0]: unknown information type 'F_Q' (known: F_A, F_G, ...)``.
    """


class InformationError(CoalitionError):
    """An information type, instance or conversion text is malformed (unknown label, arity...)."""


class RequestError(CoalitionError):
    """An information request or offer from another robot is malformed or cannot be served."""


class SearchError(CoalitionError):
    """A coalition search could not finish (e.g. its message budget was exhausted by a request loop)."""

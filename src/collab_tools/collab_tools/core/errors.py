"""The one base class of configuration errors in the workspace.

Every package's input error (a scenario field, a task file, a coalition team file, a node
parameter) derives from :class:`ConfigurationError`, whose message starts with the name or dotted
path of what is wrong and says what is allowed. ``collab_tools.node_support.run`` turns it into
exit code 2, ``scripts/*`` print it without a traceback.
"""


class ConfigurationError(ValueError):
    """An input the software cannot start with; the message names the field and the allowed values."""

"""Errors raised by the role engine core."""


class RoleEngineError(ValueError):
    """Invalid input to the role engine core.

    The message starts with the name or dotted path of the offending value and says the
    allowed range, e.g. ``robot_type.radius: must be a finite number >= 0 (got -1.0)``.
    Configuration files are read with the bridge's field readers
    (:mod:`pybullet_bridge.core.fields`), whose errors are ``ScenarioError``; both are
    ``ValueError`` subclasses with the same message style.
    """

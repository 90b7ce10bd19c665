"""Deprecated: use ``collab_tools.core.fields`` with ``error=ScenarioError``; kept until no package imports it."""
from functools import partial

import collab_tools.core.fields as _shared
from collab_tools.core.fields import NAME_PATTERN, REQUIRED, join_path, type_name  # noqa: F401

from .errors import ScenarioError

# The readers raise ScenarioError here, as this module's did.
(Fields, fail, read_yaml_file, require_mapping, require_list, check_number, check_int, check_vector, check_color,
 check_name) = (partial(getattr(_shared, name), error=ScenarioError) for name in (
    'Fields', 'fail', 'read_yaml_file', 'require_mapping', 'require_list', 'check_number', 'check_int',
    'check_vector', 'check_color', 'check_name'))

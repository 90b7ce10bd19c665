"""Import generated ROS interface classes from their type names."""

import importlib
import sys


def import_interface(type_name: str):
    """'pkg/msg/Name' (or 'pkg/srv/Name', 'pkg/action/Name', 'pkg/Name') -> the generated Python class.

    The messages rosidl generates for an action (what its topics carry), such as
    'pkg/action/Name_FeedbackMessage' or 'pkg/action/Name_Goal', are found in the module of
    the action's class: ``pkg.action`` only exports the action itself.
    """
    parts = type_name.split('/')
    if len(parts) == 2:
        parts = [parts[0], 'msg', parts[1]]
    if len(parts) != 3 or parts[1] not in ('msg', 'srv', 'action') or not all(parts):
        raise ValueError(f"interface type '{type_name}': expected 'package/msg/Name'")
    package, kind, name = parts
    try:
        module = importlib.import_module(f'{package}.{kind}')
        if kind == 'action' and not hasattr(module, name) and '_' in name:
            action = getattr(module, name.split('_', 1)[0])
            module = sys.modules[action.__module__]
        return getattr(module, name)
    except (ImportError, AttributeError, KeyError):
        raise ValueError(f"interface type '{type_name}' is not installed "
                         '(is its package built and sourced?)') from None

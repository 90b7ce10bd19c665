"""Import generated ROS interface classes from their type names."""

import importlib


def import_interface(type_name: str):
    """'pkg/msg/Name' (or 'pkg/srv/Name', 'pkg/Name') -> the generated Python class."""
    parts = type_name.split('/')
    if len(parts) == 2:
        parts = [parts[0], 'msg', parts[1]]
    if len(parts) != 3 or parts[1] not in ('msg', 'srv', 'action') or not all(parts):
        raise ValueError(f"interface type '{type_name}': expected 'package/msg/Name'")
    package, kind, name = parts
    try:
        module = importlib.import_module(f'{package}.{kind}')
        return getattr(module, name)
    except (ImportError, AttributeError):
        raise ValueError(f"interface type '{type_name}' is not installed "
                         '(is its package built and sourced?)') from None

"""Message type support for bag recording without rclpy.

A :class:`rosbags.typesys.store.Typestore` knows how to (de)serialize CDR data,
how to write the ROS 2 message definition text into an MCAP schema and how to
compute the RIHS01 type hash.  rosbags ships the standard ROS 2 Jazzy types;
everything else (the workspace's own ``bridge_interfaces``) is parsed from the
``.msg`` files that the ROS installation and the workspace overlay install
under ``<prefix>/share/<pkg>/msg/``.
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from pathlib import Path

from rosbags.interfaces import Nodetype
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

__all__ = [
    'UnknownMessageTypeError',
    'base_store_name',
    'build_typestore',
    'find_message_definitions',
    'normalize_type_name',
]


class UnknownMessageTypeError(ValueError):
    """A message type is neither in the rosbags store nor in any prefix's share/."""

    def __init__(self, type_name: str, searched: Iterable[str | Path], needed_by: str | None = None):
        self.type_name = type_name
        self.searched = [str(p) for p in searched]
        self.needed_by = needed_by
        where = ', '.join(self.searched) if self.searched else '(no prefixes: AMENT_PREFIX_PATH empty?)'
        via = f' (needed by {needed_by})' if needed_by else ''
        super().__init__(
            f'unknown message type {type_name!r}{via}: not in the rosbags {base_store_name()} store '
            f'and no share/<pkg>/msg/<Name>.msg for it under the prefixes {where}'
        )


def base_store_name() -> str:
    """Name of the rosbags store used as the base (ROS2_JAZZY when available)."""
    return 'ROS2_JAZZY' if hasattr(Stores, 'ROS2_JAZZY') else 'LATEST'


def _base_store() -> Typestore:
    return get_typestore(getattr(Stores, base_store_name()))


def normalize_type_name(type_name: str) -> str:
    """Return the ``pkg/msg/Name`` spelling of ``pkg/msg/Name`` or ``pkg/Name``.

    Raises ValueError for anything else.
    """
    parts = str(type_name).strip().strip('/').split('/')
    if len(parts) == 2 and all(parts):
        return f'{parts[0]}/msg/{parts[1]}'
    if len(parts) == 3 and all(parts) and parts[1] == 'msg':
        return '/'.join(parts)
    raise ValueError(f"invalid message type name {type_name!r}: expected 'pkg/msg/Name' or 'pkg/Name'")


def _default_prefixes() -> list[str]:
    value = os.environ.get('AMENT_PREFIX_PATH', '')
    return [p for p in value.split(os.pathsep) if p]


def _prefix_list(prefixes: Iterable[str | Path] | None) -> list[Path]:
    if prefixes is None:
        prefixes = _default_prefixes()
    if isinstance(prefixes, (str, Path)):
        prefixes = [prefixes]
    return [Path(p) for p in prefixes if str(p)]


def find_message_definitions(prefixes: Iterable[str | Path] | None = None) -> dict[str, str]:
    """Map ``'pkg/msg/Name'`` to the text of every ``<prefix>/share/<pkg>/msg/Name.msg``.

    ``prefixes`` defaults to ``AMENT_PREFIX_PATH`` (empty or unset -> ``{}``).
    Earlier prefixes win, as in an ament overlay.
    """
    found: dict[str, str] = {}
    for prefix in _prefix_list(prefixes):
        share = prefix / 'share'
        if not share.is_dir():
            continue
        for msg_file in sorted(share.glob('*/msg/*.msg')):
            name = f'{msg_file.parent.parent.name}/msg/{msg_file.stem}'
            if name in found:
                continue
            try:
                found[name] = msg_file.read_text(encoding='utf-8')
            except OSError:
                continue
    return found


def _referenced_types(fields: Iterable[tuple[str, tuple]]) -> list[str]:
    """Names of the message types that the given rosbags field descriptions use."""
    refs: list[str] = []
    for _name, desc in fields:
        node, args = desc
        if node in (Nodetype.ARRAY, Nodetype.SEQUENCE):
            node, args = args[0]
        if node == Nodetype.NAME:
            refs.append(str(args))
    return refs


def build_typestore(type_names: Iterable[str], prefixes: Iterable[str | Path] | None = None) -> Typestore:
    """A typestore that knows every type in ``type_names`` and what they nest.

    The base is rosbags' ROS2_JAZZY store; each requested type that is not in
    it, and recursively every type those nest, is parsed from the ``.msg``
    files found by :func:`find_message_definitions`.

    Raises:
        UnknownMessageTypeError: a requested (or nested) type cannot be found.
        ValueError: a malformed type name.
    """
    store = _base_store()
    wanted = [normalize_type_name(t) for t in type_names]
    if all(t in store.fielddefs for t in wanted):
        return store

    prefix_paths = _prefix_list(prefixes)
    definitions = find_message_definitions(prefix_paths)
    searched = [p / 'share' for p in prefix_paths]

    parsed: dict[str, tuple] = {}
    # (type, needed_by) work list, depth first
    todo: list[tuple[str, str | None]] = [(t, None) for t in reversed(wanted)]
    while todo:
        name, needed_by = todo.pop()
        if name in store.fielddefs or name in parsed:
            continue
        text = definitions.get(name)
        if text is None:
            raise UnknownMessageTypeError(name, searched, needed_by)
        types = get_types_from_msg(text, name)
        for typ_name, typ_def in types.items():
            parsed.setdefault(typ_name, typ_def)
        for ref in _referenced_types(types[name][1]):
            ref_name = normalize_type_name(ref) if '/msg/' not in ref else ref
            if ref_name not in store.fielddefs and ref_name not in parsed:
                todo.append((ref_name, name))

    if parsed:
        store.register(parsed)
    return store


"""Message type support for bag recording without rclpy.

A :class:`rosbags.typesys.store.Typestore` knows how to (de)serialize CDR data,
how to write the ROS 2 message definition text into an MCAP schema and how to
compute the RIHS01 type hash.  rosbags ships the standard ROS 2 Jazzy types;
everything else (the workspace's own ``bridge_interfaces``) is parsed from the
``.msg`` files that the ROS installation and the workspace overlay install
under ``<prefix>/share/<pkg>/msg/``.

An action's topics carry messages that rosidl generates from its ``.action`` file
(``share/<pkg>/action/<Name>.action``): ``<pkg>/action/<Name>_Goal``, ``_Result`` and
``_Feedback`` are its three parts, and the feedback topic carries
``<Name>_FeedbackMessage`` = ``unique_identifier_msgs/UUID goal_id`` + ``<Name>_Feedback
feedback``; the status topic carries the standard ``action_msgs/msg/GoalStatusArray``.
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterable
from pathlib import Path

from rosbags.interfaces import Nodetype
from rosbags.typesys.base import TypesysError
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

__all__ = [
    'ACTION_PARTS',
    'UnknownMessageTypeError',
    'action_definitions',
    'base_store_name',
    'build_typestore',
    'find_message_definitions',
    'message_definition',
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
        source = 'share/<pkg>/action/<Name>.action' if '/action/' in type_name else 'share/<pkg>/msg/<Name>.msg'
        super().__init__(
            f'unknown message type {type_name!r}{via}: not in the rosbags {base_store_name()} store '
            f'and no {source} for it under the prefixes {where}'
        )


#: The messages rosidl generates from an action that its topics (and parts) use.
ACTION_PARTS = ('Goal', 'Result', 'Feedback', 'FeedbackMessage')
_ACTION_SEPARATOR = re.compile(r'^---[ \t]*$', re.MULTILINE)


def base_store_name() -> str:
    """Name of the rosbags store used as the base (ROS2_JAZZY when available)."""
    return 'ROS2_JAZZY' if hasattr(Stores, 'ROS2_JAZZY') else 'LATEST'


def _base_store() -> Typestore:
    return get_typestore(getattr(Stores, base_store_name()))


def normalize_type_name(type_name: str) -> str:
    """Return the ``pkg/msg/Name`` spelling of ``pkg/msg/Name`` or ``pkg/Name``.

    An action's generated messages keep theirs: ``pkg/action/Name_Goal`` (``_Result``,
    ``_Feedback``, ``_FeedbackMessage``). Raises ValueError for anything else.
    """
    parts = str(type_name).strip().strip('/').split('/')
    if len(parts) == 2 and all(parts):
        return f'{parts[0]}/msg/{parts[1]}'
    if len(parts) == 3 and all(parts) and parts[1] == 'msg':
        return '/'.join(parts)
    if len(parts) == 3 and all(parts) and parts[1] == 'action' and '_' in parts[2] \
            and parts[2].split('_', 1)[1] in ACTION_PARTS and parts[2].split('_', 1)[0]:
        return '/'.join(parts)
    raise ValueError(f"invalid message type name {type_name!r}: expected 'pkg/msg/Name', 'pkg/Name' or "
                     f"an action's 'pkg/action/Name_<{'|'.join(ACTION_PARTS)}>'")


def _default_prefixes() -> list[str]:
    value = os.environ.get('AMENT_PREFIX_PATH', '')
    return [p for p in value.split(os.pathsep) if p]


def _prefix_list(prefixes: Iterable[str | Path] | None) -> list[Path]:
    if prefixes is None:
        prefixes = _default_prefixes()
    if isinstance(prefixes, (str, Path)):
        prefixes = [prefixes]
    return [Path(p) for p in prefixes if str(p)]


def action_definitions(package: str, action: str, text: str) -> dict[str, str]:
    """The ``.msg`` texts of the messages rosidl generates from an ``.action`` file's text.

    Raises ValueError when the text is not three parts separated by ``---`` lines.
    """
    parts = _ACTION_SEPARATOR.split(text)
    if len(parts) != 3:
        raise ValueError(f'{package}/action/{action}.action: expected goal, result and feedback '
                         f'separated by two --- lines (found {len(parts) - 1})')
    prefix = f'{package}/action/{action}'
    goal, result, feedback = parts
    return {
        f'{prefix}_Goal': goal,
        f'{prefix}_Result': result,
        f'{prefix}_Feedback': feedback,
        # As rosidl generates it (rosidl_parser: the feedback message of an action).
        f'{prefix}_FeedbackMessage': f'unique_identifier_msgs/UUID goal_id\n{prefix}_Feedback feedback\n',
    }


def find_message_definitions(prefixes: Iterable[str | Path] | None = None) -> dict[str, str]:
    """Map ``'pkg/msg/Name'`` to the text of every ``<prefix>/share/<pkg>/msg/Name.msg``.

    Every ``<prefix>/share/<pkg>/action/Name.action`` adds its generated messages
    (see :func:`action_definitions`) as ``'pkg/action/Name_<Part>'``.
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
        for action_file in sorted(share.glob('*/action/*.action')):
            package = action_file.parent.parent.name
            if f'{package}/action/{action_file.stem}_Goal' in found:
                continue
            try:
                found.update(action_definitions(package, action_file.stem, action_file.read_text(encoding='utf-8')))
            except (OSError, ValueError):
                continue  # a broken file: its types stay unknown, which names the searched prefixes
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


def _parse(text: str, name: str) -> dict[str, tuple]:
    """rosbags field definitions of the message ``name`` from its ``.msg`` text."""
    package, kind, short = name.split('/')
    if kind != 'action':
        return get_types_from_msg(text, name)
    # A relative type in an .action file is a message of the same package (pkg/msg/X),
    # which rosbags finds when the text is parsed as a message of that package.
    types = get_types_from_msg(text, f'{package}/msg/{short}')
    return {name: types[f'{package}/msg/{short}']}


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
        types = _parse(text, name)
        for typ_name, typ_def in types.items():
            parsed.setdefault(typ_name, typ_def)
        for ref in _referenced_types(types[name][1]):
            ref_name = normalize_type_name(ref) if '/msg/' not in ref else ref
            if ref_name not in store.fielddefs and ref_name not in parsed:
                todo.append((ref_name, name))

    if parsed:
        store.register(parsed)
    return store



def _definition_name(type_name: str) -> str:
    # rosbag2 names a message 'pkg/Name' in a definition; an action's generated message
    # has no such short form and keeps 'pkg/action/Name_Part'.
    package, kind, name = type_name.split('/')
    return f'{package}/{name}' if kind == 'msg' else type_name


def _field_text(desc: tuple) -> tuple[str, str | None]:
    """('type text', nested type name or None) of one rosbags field description."""
    node, args = desc
    if node == Nodetype.BASE:
        name, limit = args
        return (f'string<={limit}' if name == 'string' and limit else name), None
    if node == Nodetype.NAME:
        return _definition_name(args), args
    (inner_node, inner), count = args
    bound = '' if not count else str(count) if node == Nodetype.ARRAY else f'<={count}'
    if inner_node == Nodetype.BASE:
        name, limit = inner
        return f'{f"string<={limit}" if name == "string" and limit else name}[{bound}]', None
    return f'{_definition_name(inner)}[{bound}]', inner


def message_definition(store: Typestore, type_name: str) -> str:
    """The ROS 2 message definition (``ros2msg``) of ``type_name`` as rosbag2 writes it into an MCAP schema.

    The type's fields, then every nested type once, each after a line of 80 ``=`` and
    ``MSG: <type>``. Unlike rosbags' own generator it also covers an action's generated
    messages (``pkg/action/Name_FeedbackMessage``). Raises TypesysError for an unknown type.
    """
    order: list[str] = []
    texts: dict[str, str] = {}

    def render(name: str) -> None:
        if name not in store.fielddefs:
            raise TypesysError(f'Type {name!r} is unknown.')
        texts[name] = ''
        consts, fields = store.fielddefs[name]
        lines = [f'{typ} {const}={value}' for const, typ, value in consts]
        for field, desc in fields:
            if field == 'structure_needs_at_least_one_member':
                continue
            text, nested = _field_text(desc)
            lines.append(f'{text} {field}')
            if nested is not None and nested not in texts:
                order.append(nested)
                render(nested)
        texts[name] = '\n'.join(lines) + '\n'

    render(type_name)
    return ''.join([texts[type_name], *(f'{"=" * 80}\nMSG: {_definition_name(n)}\n{texts[n]}' for n in order)])

"""Scenario sections: the registry of top-level keys that hold entities, and what their parsers get.

A section parser is ``parser(value, context) -> [definition]``: it validates its YAML value and
returns pure definitions of the entities (no simulator), which :class:`.scene.Scene` later turns
into simulated bodies. :mod:`.scenario` registers the built-in sections in label order; later
kinds register themselves with :func:`register_section` without editing the scenario loader.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Mapping

from .world import WorldConfig

if TYPE_CHECKING:
    from .entity import EntityDefinition

#: Top-level keys of a scenario that are not sections.
TOP_LEVEL_KEYS = ('name', 'seed', 'world', 'camera', 'robot_types')


@dataclass
class SectionContext:
    """What a section parser may need besides its own YAML value."""

    path: str                       # dotted path of the section, e.g. 'mobile_robots'
    base_dir: Path                  # directory relative file paths are resolved against
    world: WorldConfig
    robot_types: dict[str, dict[str, float]]
    seed: int | None
    #: Entities of the sections parsed before this one, by section key (read only), so a
    #: section can check itself against earlier ones (cubes must rest on tables, arms must
    #: not stand in them).
    earlier: Mapping[str, list] = field(default_factory=dict)

    def resolve(self, relative: str) -> Path:
        """Resolve a path written in the scenario file."""
        return (self.base_dir / relative).resolve()


SectionParser = Callable[[Any, SectionContext], 'list[EntityDefinition]']

_SECTION_PARSERS: dict[str, SectionParser] = {}


def register_section(key: str, parser: SectionParser) -> None:
    """Let top-level key ``key`` be parsed by ``parser(value, context) -> [definition]``.

    Registering an existing key replaces its parser but keeps its position in the
    spawn order. Entities get labels in registration order of their sections.
    """
    if not isinstance(key, str) or not key.isidentifier():
        raise ValueError(f'section key must be an identifier (got {key!r})')
    if key in TOP_LEVEL_KEYS:
        raise ValueError(f"section key '{key}' is reserved (reserved: {', '.join(TOP_LEVEL_KEYS)})")
    if not callable(parser):
        raise ValueError(f"parser for section '{key}' is not callable")
    _SECTION_PARSERS[key] = parser


def unregister_section(key: str) -> None:
    """Forget a section (mainly for tests that register temporary kinds)."""
    _SECTION_PARSERS.pop(key, None)


def registered_sections() -> list[str]:
    """Keys of every registered section, in spawn order (the built-ins once :mod:`.scenario` is imported)."""
    return list(_SECTION_PARSERS)


def section_parsers() -> dict[str, SectionParser]:
    """Every registered section's parser by key, in spawn order (a copy)."""
    return dict(_SECTION_PARSERS)

"""An experiment's inputs from the command line instead of the tracked config/ files: ``--config`` and ``--set``.

``--config DIR``: a directory laid out like config/; every file it has replaces the tracked one
(the others stay the tracked ones). ``--config FILE``: replaces the experiment's main input file
(:attr:`~.api.Experiment.config_file`, e.g. roles/experiments.yaml). ``--set key=value`` (repeatable)
changes one field of that main file: ``key`` is a dotted path of keys that exist in it (list items
by index: ``table4.robot_groups.0.count=2``), ``value`` is YAML (``2``, ``0.5``, ``[0.1, 0.15]``,
``true``, ``text``) of the same kind as the field's; unknown keys and other kinds are refused,
naming them, before anything runs; the experiment then validates the edited file like any other.

:func:`plan_inputs` checks all that and writes nothing; :meth:`InputPlan.materialise` writes the
run's configuration directory, ``RUN_DIR/inputs/config``: symbolic links to the tracked (and
``--config DIR``) files, with the main file a real copy (the record of what ran). Relative paths
inside a replaced or edited main file therefore resolve as in the tracked file it replaces.
"""
from __future__ import annotations

import os
import shutil
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

import yaml

from ..core.errors import ConfigurationError
from ..core.input_files import load_yaml_text, read_text_file, shown_path
from ..core.settings import echo

OVERLAY = Path('inputs') / 'config'


def parse_settings(pairs: Sequence[str] | None) -> dict[str, Any]:
    """``['a.b=2', ...]`` -> ``{'a.b': 2, ...}`` (values parsed as YAML); errors name the pair."""
    settings: dict[str, Any] = {}
    for pair in pairs or ():
        key, separator, text = pair.partition('=')
        key = key.strip()
        if not separator or not key or any(not part for part in key.split('.')):
            raise ConfigurationError(f"--set {pair}: expected key=value with a dotted key (e.g. "
                                     'table4.problems_per_environment=2)')
        if not text.strip():
            raise ConfigurationError(f'--set {pair}: no value after =')
        try:
            settings[key] = load_yaml_text(text)
        except ConfigurationError as error:
            raise ConfigurationError(f'--set {echo(pair)[1:-1]}: the value is not YAML ({error})') from None
    return settings


def _kind(value: Any) -> str:
    if isinstance(value, bool):
        return 'boolean'
    if isinstance(value, (int, float)):
        return 'number'
    if isinstance(value, str):
        return 'text'
    if isinstance(value, list):
        return 'list'
    if isinstance(value, dict):
        return 'mapping'
    return 'null' if value is None else type(value).__name__


def apply_settings(data: Any, settings: dict[str, Any], where: str) -> Any:
    """``data`` (a YAML document) with each dotted key set; an unknown key or a value of another kind than
    the field's is a ConfigurationError naming the key (``where``: the file, for the message)."""
    for key, value in settings.items():
        parts = key.split('.')
        node = data
        for depth, part in enumerate(parts):
            here = '.'.join(parts[:depth]) or 'the top level'
            last = depth == len(parts) - 1
            if isinstance(node, dict):
                if part not in node:
                    raise ConfigurationError(f"--set {key}: unknown key {part!r} at {here} of {where} "
                                             f"(keys there: {', '.join(map(str, node)) or 'none'})")
                slot = part
            elif isinstance(node, list):
                if not part.isdigit() or int(part) >= len(node):
                    raise ConfigurationError(f'--set {key}: {part!r} at {here} of {where} must be an index '
                                             f'0..{len(node) - 1} (it is a list)')
                slot = int(part)
            else:
                raise ConfigurationError(f'--set {key}: {here} of {where} is a {_kind(node)}, it has no keys')
            if last:
                old = node[slot]
                if old is not None and _kind(old) != _kind(value):
                    raise ConfigurationError(f'--set {key}={echo(value)}: {where} has a {_kind(old)} there '
                                             f'({echo(old)}), not a {_kind(value)}')
                node[slot] = value
            else:
                node = node[slot]
    return data


def _read_yaml(path: Path, what: str) -> Any:
    text = read_text_file(path, what)       # regular files only, bounded (core.input_files)
    try:
        return load_yaml_text(text)
    except ConfigurationError as error:
        raise ConfigurationError(f"{what} '{shown_path(path)}': {error}") from None


@dataclass(frozen=True)
class InputPlan:
    """Where a run's configuration comes from (validated; nothing written yet)."""

    base: Path                                   # the tracked config/
    directory: Path | None = None                # --config DIR
    file: Path | None = None                     # --config FILE
    main: str | None = None                      # the experiment's main file, relative to config/
    merged: Any = None                           # the main file's data after --set (None: no --set)
    settings: dict[str, Any] = field(default_factory=dict)

    @property
    def changed(self) -> bool:
        return self.directory is not None or self.file is not None or bool(self.settings)

    def record(self) -> dict[str, Any]:
        """What the command line gave (results.json options, run.json)."""
        given = {}
        if self.directory is not None or self.file is not None:
            given['config'] = str(self.directory or self.file)
        if self.settings:
            given['set'] = dict(self.settings)
        return given

    def config_dir(self, run_dir: Path) -> Path:
        return Path(run_dir) / OVERLAY if self.changed else self.base

    def materialise(self, run_dir: str | Path) -> Path:
        """The run's configuration directory (the tracked config/ itself when nothing changes it); an
        existing one (a resumed run) is kept as it was written."""
        target = self.config_dir(Path(run_dir))
        if not self.changed or target.exists():
            return target
        layers = [self.base] + ([self.directory] if self.directory is not None else [])
        _overlay(target, layers)
        if self.main is not None and (self.file is not None or self.settings):
            main = target / self.main
            _make_real_parents(target, Path(self.main).parent)
            if main.is_symlink() or main.exists():
                main.unlink()
            if self.settings:
                main.write_text(f'# {self.main} with --set {self.settings} (scripts/experiment)\n'
                                + yaml.safe_dump(self.merged, sort_keys=False))
            else:
                shutil.copyfile(self.file, main)
        return target


def _overlay(target: Path, layers: list[Path]) -> None:
    """``target`` holding every entry of ``layers`` (later layers win) as symbolic links; directories
    present in several layers are merged one level further down."""
    target.mkdir(parents=True)
    names = sorted(set().union(*(os.listdir(layer) for layer in layers if layer.is_dir())))
    for name in names:
        sources = [layer / name for layer in layers if (layer / name).exists()]
        if len(sources) > 1 and all(source.is_dir() for source in sources):
            _overlay(target / name, sources)
        else:
            (target / name).symlink_to(sources[-1].resolve())


def _make_real_parents(root: Path, relative: Path) -> None:
    """Each directory from ``root`` down to ``root/relative`` a real one (a linked one is unfolded into
    links to its entries), so a file can be written there without touching the linked originals."""
    here = root
    for part in relative.parts:
        here = here / part
        if here.is_symlink():
            source = here.resolve()
            here.unlink()
            _overlay(here, [source])
        elif not here.exists():
            here.mkdir()


def plan_inputs(base: Path, config: str | Path | None, pairs: Sequence[str] | None, *, name: str,
                main: str | None, own_option: str | None = None, own_option_given: bool = False) -> InputPlan:
    """Check ``--config`` and ``--set`` of experiment ``name`` (main input file ``main``; its own option
    naming that file, ``own_option``, given or not). ConfigurationError naming what is wrong."""
    base = Path(base)
    settings = parse_settings(pairs)
    directory = file = None
    if config is not None:
        path = Path(config).expanduser()
        if path.is_dir():
            directory = path.resolve()
        elif path.is_file():
            file = path.resolve()
            if main is None:
                raise ConfigurationError(f"--config {config}: {name} reads several files and has no main one; "
                                         'give a directory laid out like config/ instead')
        else:
            raise ConfigurationError(f"--config: '{config}' is neither a directory nor a file")
    if settings and main is None:
        raise ConfigurationError(f'--set: {name} has no main input file to edit; use --config DIR with '
                                 'edited copies of its files')
    flag = '--' + (own_option or '').replace('_', '-')
    if own_option_given and (file is not None or settings):
        raise ConfigurationError(f"{flag} and {'--config FILE' if file is not None else '--set'}: both give "
                                 f'the file {main}; use one of them')
    merged = None
    if settings:
        source = file or (directory / main if directory is not None and (directory / main).is_file()
                          else base / main)
        merged = apply_settings(_read_yaml(source, 'config file'), settings, str(source))
    return InputPlan(base=base, directory=directory, file=file, main=main, merged=merged, settings=settings)

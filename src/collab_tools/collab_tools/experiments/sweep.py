"""An experiment's loop over its steps: progress with elapsed time and ETA, each finished step saved at once
(checkpoint) and skipped when the run is resumed; :func:`sweep` runs one function over a list of cases that way."""
from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Sequence
from typing import Any, TypeVar

from .checkpoint import Checkpoint
from .progress import Log, Progress

Case = TypeVar('Case')
Row = TypeVar('Row')


class Steps:
    """The ``total`` steps of one loop (``label``), each named by a key unique in the loop.

    A step restored from the checkpoint (``has``/``value``) is not run again; ``finish`` saves a step's
    JSON-able value before it reports progress and calls ``on_step`` (a test's interruption hook), so
    an interruption never loses a finished step. Use it as a context manager (closes the bar).
    """

    def __init__(self, label: str, total: int, checkpoint: Checkpoint | None = None, log: Log = print,
                 on_step: Callable[[str], None] | None = None, bar: bool | None = None):
        self.label = label
        self.checkpoint = checkpoint
        self.on_step = on_step
        self.restored = checkpoint.load(label) if checkpoint is not None else {}
        self.progress = Progress(label, total, log, done=len(self.restored), bar=bar)
        if self.restored:
            self.progress.note(f'[{label}] resumed: {len(self.restored)} of {total} steps restored from '
                               f'{checkpoint.directory}')

    def has(self, key: str) -> bool:
        return str(key) in self.restored

    def value(self, key: str) -> Any:
        return self.restored[str(key)]

    def finish(self, key: str, value: Any, text: str) -> None:
        """Step ``key`` gave ``value``: saved first, then reported."""
        if self.checkpoint is not None:
            self.checkpoint.save(self.label, key, value)
        self.progress.advance(text)
        if self.on_step is not None:
            self.on_step(str(key))

    def checkpointed(self, function: Callable[..., Row], key: Callable[..., str],
                     encode: Callable[[Row], Any] = lambda row: row, decode: Callable[[Any], Row] = lambda value: value,
                     describe: Callable[[Row], str] = lambda row: 'done') -> Callable[..., Row]:
        """``function`` as one step per call (named ``key(*args)``): restored when saved, else run and saved
        (``encode``/``decode``: to and from a JSON-able form) -- for a loop that lives in code of its own."""
        def step(*args):
            name = key(*args)
            if self.has(name):
                return decode(self.value(name))
            began = time.monotonic()
            row = function(*args)
            self.finish(name, encode(row), f'{name}: {describe(row)} ({time.monotonic() - began:.1f} s)')
            return row
        return step

    def close(self) -> None:
        self.progress.close()

    def __enter__(self) -> 'Steps':
        return self

    def __exit__(self, *_exc) -> None:
        self.close()


def sweep(label: str, cases: Sequence[Case], run_one: Callable[[Case], Row], log: Log = print,
          name: Callable[[Case], str] = str, describe: Callable[[Row], str] | None = None, *, request=None,
          encode: Callable[[Row], Any] = lambda row: row, decode: Callable[[Any], Row] = lambda value: value
          ) -> list[Row]:
    """``[run_one(c) for c in cases]`` with a progress line per case (``[label i/n] <name>: <describe(row)>
    (t s)``). Given the run's ``request`` (an ExperimentRequest), each row is checkpointed under its case's
    name (``encode``: a JSON-able form, ``decode``: back) and a resumed run restores it instead."""
    rows = []
    steps = (request.progress(label, len(cases)) if request is not None
             else Steps(label, len(cases), log=log, bar=False))
    with steps:
        for case in cases:
            key = name(case)
            if steps.has(key):
                rows.append(decode(steps.value(key)))
                continue
            start = time.monotonic()
            row = run_one(case)
            rows.append(row)
            detail = f' {describe(row)}' if describe is not None else ''
            steps.finish(key, encode(row), f'{key}:{detail} ({time.monotonic() - start:.1f} s)')
    return rows


def select(items: Iterable[Case], only: Iterable[str] | None, name: Callable[[Case], str], what: str) -> list[Case]:
    """The items whose names are in ``only`` (all when None); an unknown name is a ValueError naming it."""
    items = list(items)
    if not only:
        return items
    wanted = list(only)
    known = {name(item) for item in items}
    unknown = [w for w in wanted if w not in known]
    if unknown:
        raise ValueError(f"--only: unknown {what} {', '.join(unknown)} (known: {', '.join(sorted(known))})")
    return [item for item in items if name(item) in wanted]


def median(values: Iterable[Any]) -> float | None:
    ordered = sorted(v for v in values if v is not None)
    if not ordered:
        return None
    middle = len(ordered) // 2
    return float(ordered[middle]) if len(ordered) % 2 else (ordered[middle - 1] + ordered[middle]) / 2.0

"""Running one function over a list of cases with a progress line per case."""
from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Sequence
from typing import Any, TypeVar

Case = TypeVar('Case')
Row = TypeVar('Row')


def sweep(label: str, cases: Sequence[Case], run_one: Callable[[Case], Row], log: Callable[[str], None] = print,
          name: Callable[[Case], str] = str, describe: Callable[[Row], str] | None = None) -> list[Row]:
    """``[run_one(c) for c in cases]``, logging ``[label] i/n <name> ... <describe(row)> (t s)`` as each ends."""
    rows = []
    total = len(cases)
    for index, case in enumerate(cases, 1):
        start = time.monotonic()
        row = run_one(case)
        rows.append(row)
        detail = f' {describe(row)}' if describe is not None else ''
        log(f'[{label}] {index}/{total} {name(case)}:{detail} ({time.monotonic() - start:.1f} s)')
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

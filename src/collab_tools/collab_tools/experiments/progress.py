"""Progress of an experiment's loop: a tqdm bar (elapsed time, ETA) on a terminal, plain lines elsewhere.

One line per finished step is kept in both cases (``[label i/n] what happened (3.2 s)``): on a
terminal it scrolls above the bar (``tqdm.write``); in a log or CI it carries the elapsed time and
the ETA itself, so logs stay readable and grep-able. ``COLLAB_PROGRESS=plain`` forces plain lines.
"""
from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable

Log = Callable[[str], None]
_bars: list = []     # the bars drawn now (innermost last): write() prints above them


def write(text: str) -> None:
    """``print``, above the progress bar when one is drawn (the command's log for every experiment line)."""
    if _bars:
        _bars[-1].write(text, file=sys.stdout)
    else:
        print(text)


def clock_text(seconds: float) -> str:
    """``42 s``, ``3 min 05 s`` or ``1 h 02 min``."""
    seconds = max(0, int(round(seconds)))
    if seconds < 60:
        return f'{seconds} s'
    if seconds < 3600:
        return f'{seconds // 60} min {seconds % 60:02d} s'
    return f'{seconds // 3600} h {seconds % 3600 // 60:02d} min'


def wants_bar(log: Log) -> bool:
    """A bar only for the default printer on a terminal (tests and quiet callers pass their own log)."""
    return log in (print, write) and sys.stdout.isatty() and os.environ.get('COLLAB_PROGRESS', '') != 'plain'


def _size_known() -> bool:
    """The terminal reports its size (a pseudo-terminal without one says 0 x 0: tqdm would draw nothing)."""
    try:
        size = os.get_terminal_size(sys.stderr.fileno())
        return size.columns > 0 and size.lines > 0
    except (OSError, ValueError):
        return False


class Progress:
    """``total`` steps of which ``done`` are finished already (a resumed run): ``advance(text)`` per step."""

    def __init__(self, label: str, total: int, log: Log = print, done: int = 0, bar: bool | None = None):
        self.label, self.total, self.log = label, int(total), log
        self.done = int(done)
        self._resumed = int(done)
        self._started = time.monotonic()
        self._bar = None
        if bar if bar is not None else wants_bar(log):
            from tqdm import tqdm   # imported here: listing experiments must stay light

            self._bar = tqdm(total=self.total, initial=self.done, desc=label, unit='step', file=sys.stderr,
                             leave=False, **({'dynamic_ncols': True} if _size_known() else {'ncols': 100, 'nrows': 24}))
            _bars.append(self._bar)

    def elapsed(self) -> float:
        return time.monotonic() - self._started

    def eta(self) -> float | None:
        """Seconds left at this session's pace (steps restored from a checkpoint took no time here)."""
        finished_here = self.done - self._resumed
        if finished_here <= 0:
            return None
        return self.elapsed() / finished_here * (self.total - self.done)

    def advance(self, text: str) -> None:
        """One more step finished; ``text`` says what it gave."""
        self.done += 1
        line = f'[{self.label} {self.done}/{self.total}] {text}'
        if self._bar is not None:
            self._bar.update(1)
            self._bar.write(line, file=sys.stdout)
            return
        eta = self.eta()
        timing = f'elapsed {clock_text(self.elapsed())}' + ('' if eta is None or self.done >= self.total
                                                            else f', ETA {clock_text(eta)}')
        self.log(f'{line} [{timing}]')

    def note(self, text: str) -> None:
        """A line that is no step (e.g. how many steps a resumed run skips)."""
        if self._bar is not None:
            self._bar.write(text, file=sys.stdout)
        else:
            self.log(text)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            _bars.remove(self._bar)
            self._bar = None

"""A core behaviour's log lines (``port.log(level, text, throttle)``) on a node's rclpy logger.

Cores log through their port with a level name (info, warn/warning, error). rclpy keys a logger's
severity and throttling by the calling line and refuses a line whose severity changes, so each
severity has its own call below, and throttling is done here, per level and message kind (the text
without its numbers): a throttled warning of one kind never silences another kind.
"""
from __future__ import annotations

import re
import time

_NUMBERS = re.compile(r'[0-9.]+')


class PortLogger:
    """``PortLogger(node.get_logger()).log`` is a port's ``log``."""

    def __init__(self, logger):
        self._logger = logger
        self._last: dict[tuple[str, str], float] = {}

    def log(self, level: str, text: str, throttle: float = 0.0) -> None:
        if throttle:
            key = (level, _NUMBERS.sub('#', text))
            now = time.monotonic()
            if now - self._last.get(key, -float('inf')) < throttle:
                return
            self._last[key] = now
        # One call per severity: rclpy refuses a call site whose severity changes between calls.
        if level == 'info':
            self._logger.info(text)
        elif level in ('warn', 'warning'):
            self._logger.warning(text)
        else:
            self._logger.error(text)

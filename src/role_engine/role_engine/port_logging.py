"""The core behaviours' log lines (``port.log(level, text, throttle)``) on a node's rclpy logger.

rclpy throttles per call site, and every core line of a severity reaches the logger through one call
below, so throttling is done here instead, per level and message kind (the text without its numbers):
a throttled warning of one kind never silences another kind.
"""
from __future__ import annotations

import re
import time

_NUMBERS = re.compile(r'[0-9.]+')


class PortLogger:
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
        elif level == 'warn':
            self._logger.warning(text)
        else:
            self._logger.error(text)

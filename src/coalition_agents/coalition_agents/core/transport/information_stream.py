"""The stream that keeps a coalition's information flowing (no ROS).

Once a coalition is set up, the information it was formed for has to keep flowing: the paper's
Fig. 9 shows the "constant information flows (between different robots) required to maintain
the coalitions" and Fig. 11 (d) robots "helped to achieve localization via constant information
sharing". The search only handles labels (F_R(robot_1, robot_2)); execution needs their values.

Values are those of :mod:`..value_fields` (field name -> float).

:class:`InformationStream` is one robot's record of streamed values: the latest value per
(provider, instance) wins -- by the provider's sequence number, since links reorder messages --
and a value is *stale* ``timeout_s`` after it arrived. Streaming is loss-tolerant rather than
reliable (no ACKs, no retries): a lost sample is replaced by the next one, and a provider that
stops sending shows up as stale information (what the execution monitor acts on,
:mod:`..coalition_execution`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable, Mapping

from ..errors import RequestError
from ..information import InformationInstance


@dataclass(frozen=True)
class StreamedValue:
    """The value of ``instance`` from ``provider``: its ``sequence`` (the provider's message id,
    increasing) and when it arrived (``received_at``, the receiver's clock)."""

    provider: str
    instance: InformationInstance
    value: Mapping[str, float]
    sequence: int
    received_at: float


class InformationStream:
    """Latest streamed value per (provider, instance), with stale detection (module docstring)."""

    def __init__(self, timeout_s: float):
        if isinstance(timeout_s, bool) or not isinstance(timeout_s, (int, float)) or not timeout_s > 0:
            raise RequestError(f'stream_timeout: must be a number > 0 s (got {timeout_s!r})')
        self.timeout_s = float(timeout_s)
        self._latest: dict[tuple[str, InformationInstance], StreamedValue] = {}
        self.received = 0
        self.out_of_order = 0

    def update(self, provider: str, instance: InformationInstance, value: Mapping[str, float], sequence: int,
               now: float) -> bool:
        """Record a sample; False (and ignored) when a later one of the same information arrived first."""
        key = (provider, instance)
        self.received += 1
        kept = self._latest.get(key)
        if kept is not None and kept.sequence >= sequence:
            self.out_of_order += 1
            return False
        self._latest[key] = StreamedValue(provider, instance, dict(value), sequence, now)
        return True

    def value(self, provider: str, instance: InformationInstance, now: float) -> Mapping[str, float] | None:
        """The current value, or None when none arrived or it is stale."""
        kept = self._latest.get((provider, instance))
        if kept is None or now - kept.received_at > self.timeout_s:
            return None
        return kept.value

    def age(self, provider: str, instance: InformationInstance, now: float) -> float:
        """Seconds since the latest value arrived (inf when none did)."""
        kept = self._latest.get((provider, instance))
        return math.inf if kept is None else now - kept.received_at

    def stale(self, needed: Iterable[tuple[str, InformationInstance]], now: float) -> list[tuple[str, InformationInstance]]:
        """The (provider, instance) pairs of ``needed`` without a current value."""
        return [key for key in needed if self.value(key[0], key[1], now) is None]

    def forget(self, provider: str | None = None) -> None:
        """Drop every value (of ``provider``): a new coalition starts from fresh samples."""
        if provider is None:
            self._latest.clear()
        else:
            for key in [key for key in self._latest if key[0] == provider]:
                del self._latest[key]


__all__ = ['InformationStream', 'StreamedValue']

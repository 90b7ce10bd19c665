"""Whether a set-up coalition is still feasible while it executes, and when to re-form (no ROS).

The issue: the agent "re-forms when feasibility changes during execution". A coalition was chosen
because every information source of its local coalition solution could be instantiated; during
execution those sources are the helpers' streams (:mod:`.transport.information_stream`) and the leader's
own sensor readings. :class:`CoalitionExecution` watches exactly those sources:

* each CS leaf needs a current value from its provider (the stream of the instance it offered;
  for a request the robot answered itself, footnote 10, its own current answer);
* each ES-EPS leaf needs a current reading of the leader's own sensor (e.g. it still sees the
  helper it localises from).

A source without a current value makes the coalition *infeasible*; if it stays so for
``reform_timeout_s`` (continuously; ``inf``: never), :meth:`check` says ``reform``: the leader releases the
coalition (its helpers' commitments go back through the channel) and searches again. The grace
time starts when the coalition is established too, so helpers have time to start streaming.
Choices (the paper gives no timeouts): a source is checked only for presence and freshness, not
for its values, so a value conversion that cannot run (e.g. no heading known yet) makes the motor
schema wait (:mod:`.information_values`) but never re-forms the coalition on its own.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

from .coalition_solution import LocalCoalitionSolution
from .errors import ConfigError
from .information import InformationInstance
from .schemas import SchemaKind


@dataclass(frozen=True)
class ExecutionCheck:
    """``feasible`` now; ``missing``: the sources without a current value (text);
    ``lost_helpers``: providers whose streams are missing; ``reform``: give the coalition up."""

    feasible: bool
    missing: tuple[str, ...]
    lost_helpers: tuple[str, ...]
    infeasible_for: float
    reform: bool


class CoalitionExecution:
    """The feasibility of one established coalition of this robot (module docstring)."""

    def __init__(self, lcs: LocalCoalitionSolution, established_at: float, reform_timeout_s: float):
        if isinstance(reform_timeout_s, bool) or not isinstance(reform_timeout_s, (int, float)) \
                or math.isnan(reform_timeout_s) or reform_timeout_s <= 0:
            raise ConfigError(f'reform_timeout: must be a number > 0 s, inf = never (got {reform_timeout_s!r})')
        self.lcs = lcs
        self.reform_timeout_s = float(reform_timeout_s)
        #: (provider, instance) of every CS leaf
        self.streams: tuple[tuple[str, InformationInstance], ...] = tuple(
            (offer.provider, offer.instance) for _, _, offer in lcs.sources if offer is not None)
        #: (sensor, instance) of every own ES-EPS leaf
        self.readings: tuple[tuple[str, InformationInstance], ...] = tuple(
            (step.schema, instance) for step, instance, offer in lcs.sources
            if offer is None and step.kind is SchemaKind.ES_EPS)
        self._feasible_at = established_at

    @property
    def helpers(self) -> tuple[str, ...]:
        return tuple(dict.fromkeys(provider for provider, _ in self.streams if provider != self.lcs.robot))

    def check(self, now: float, stream_current: Callable[[str, InformationInstance], bool],
              reading_current: Callable[[str, InformationInstance], bool]) -> ExecutionCheck:
        """Evaluate at ``now``; ``stream_current(provider, instance)`` and
        ``reading_current(sensor, instance)`` say whether a current value exists."""
        missing, lost = [], []
        for provider, instance in self.streams:
            if not stream_current(provider, instance):
                missing.append(f'{instance} from {provider}')
                if provider != self.lcs.robot:  # footnote 10: a self-request is no helper
                    lost.append(provider)
        for sensor, instance in self.readings:
            if not reading_current(sensor, instance):
                missing.append(f'{instance} from own {sensor}')
        if not missing:
            self._feasible_at = now
        infeasible_for = now - self._feasible_at
        return ExecutionCheck(not missing, tuple(missing), tuple(dict.fromkeys(lost)), infeasible_for,
                              bool(missing) and infeasible_for >= self.reform_timeout_s)


__all__ = ['CoalitionExecution', 'ExecutionCheck']

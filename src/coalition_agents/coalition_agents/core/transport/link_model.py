"""The link model of the agent-to-agent channel: message delay and loss, seeded.

Paper, Section V-B-4 (Fig. 9): the communication delay T_D "is implemented to follow a normal
distribution N(mu, sigma) in which mu = 3.85 ms and sigma = 5.05 ms" (measured on 802.11n);
the paper's bound (1) assumes no message loss. The issue adds a loss probability so that the
retrying channel (:mod:`.reliable_channel`) can be exercised.

Choices where the paper is silent:

* A delay cannot be negative, and N(3.85 ms, 5.05 ms) puts 22 % of its mass below 0. The
  ``normal`` distribution is therefore *truncated* at 0 (negative draws are redrawn), not
  clipped (clipping would deliver 22 % of the messages after exactly 0 s). The truncated
  distribution's mean and standard deviation (5.79 ms and 3.78 ms for the paper's preset) are
  :meth:`DelayDistribution.mean` / :meth:`DelayDistribution.std`.
* Each call of :meth:`LinkModel.sample` is one message on one link (sender -> receiver); loss
  and delay are independent between messages, so a broadcast is sampled per receiver.

Configuration (YAML or dict; every error names the field path and the allowed range)::

    link:
      preset: paper_fig9            # optional; fields below override it
      delay: {distribution: normal, mean_s: 0.00385, std_s: 0.00505}
      #      {distribution: constant, value_s: 0.01}
      #      {distribution: uniform, low_s: 0.0, high_s: 0.02}
      loss_probability: 0.2         # in [0, 1]
      seed: 7                       # optional; None draws a fresh seed
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from collab_tools.core.fields import Fields, require_mapping, type_name as describe_type

from ..errors import ConfigError

DISTRIBUTIONS = ('normal', 'constant', 'uniform')

#: Named link configurations. ``paper_fig9``: the paper's measured 802.11n delay, no loss.
PRESETS: dict[str, dict[str, Any]] = {
    'paper_fig9': {'delay': {'distribution': 'normal', 'mean_s': 0.00385, 'std_s': 0.00505},
                   'loss_probability': 0.0},
    'ideal': {'delay': {'distribution': 'constant', 'value_s': 0.0}, 'loss_probability': 0.0},
}

_DISTRIBUTION_FIELDS = {
    'normal': ('distribution', 'mean_s', 'std_s'),
    'constant': ('distribution', 'value_s'),
    'uniform': ('distribution', 'low_s', 'high_s'),
}


@dataclass(frozen=True)
class DelayDistribution:
    """One-way message delay in seconds: ``normal`` (truncated at 0), ``constant`` or ``uniform``."""

    distribution: str
    mean_s: float = 0.0
    std_s: float = 0.0
    value_s: float = 0.0
    low_s: float = 0.0
    high_s: float = 0.0

    def __post_init__(self) -> None:
        if self.distribution not in DISTRIBUTIONS:
            raise ConfigError(f"delay.distribution: unknown distribution '{self.distribution}' "
                              f"(allowed: {', '.join(DISTRIBUTIONS)})")
        checks = {'normal': (('std_s', self.std_s, 0.0),),
                  'constant': (('value_s', self.value_s, 0.0),),
                  'uniform': (('low_s', self.low_s, 0.0), ('high_s', self.high_s, self.low_s))}
        for name, value, lowest in checks[self.distribution]:
            if not math.isfinite(value) or value < lowest:
                raise ConfigError(f'delay.{name}: must be a finite number >= {lowest:g} (got {value!r})')
        if self.distribution == 'normal' and (not math.isfinite(self.mean_s) or (self.std_s == 0 and self.mean_s < 0)):
            raise ConfigError(f'delay.mean_s: must be finite, and >= 0 when std_s is 0 (got {self.mean_s!r})')

    @classmethod
    def from_dict(cls, data: Any, path: str = 'delay') -> 'DelayDistribution':
        mapping = require_mapping(data, path, ConfigError)
        kind = Fields(mapping, path, ('distribution', 'mean_s', 'std_s', 'value_s', 'low_s', 'high_s'),
                      error=ConfigError).string('distribution', allow_empty=True)
        if kind not in DISTRIBUTIONS:
            raise ConfigError(f"{path}.distribution: unknown distribution '{kind}' (allowed: {', '.join(DISTRIBUTIONS)})")
        section = Fields(mapping, path, _DISTRIBUTION_FIELDS[kind], error=ConfigError)
        if kind == 'normal':
            return cls(kind, mean_s=section.number('mean_s'), std_s=section.number('std_s', ge=0.0))
        if kind == 'constant':
            return cls(kind, value_s=section.number('value_s', ge=0.0))
        low = section.number('low_s', ge=0.0)
        high = section.number('high_s', ge=0.0)
        if high < low:
            raise ConfigError(f'{path}.high_s: must be >= low_s = {low:g} (got {high:g})')
        return cls(kind, low_s=low, high_s=high)

    def to_dict(self) -> dict:
        return {key: getattr(self, key) for key in _DISTRIBUTION_FIELDS[self.distribution]}

    def sample(self, rng: np.random.Generator) -> float:
        if self.distribution == 'constant':
            return self.value_s
        if self.distribution == 'uniform':
            return float(rng.uniform(self.low_s, self.high_s)) if self.high_s > self.low_s else self.low_s
        if self.std_s == 0.0:
            return self.mean_s
        while True:  # truncation at 0 by redrawing (acceptance Phi(mean/std), 78 % for the paper's preset)
            value = float(rng.normal(self.mean_s, self.std_s))
            if value >= 0.0:
                return value

    def _truncation(self) -> tuple[float, float]:
        """(alpha, lambda) of the normal truncated at 0: alpha = -mean/std, lambda = phi(alpha)/(1 - Phi(alpha))."""
        alpha = -self.mean_s / self.std_s
        tail = 0.5 * math.erfc(alpha / math.sqrt(2.0))
        density = math.exp(-0.5 * alpha * alpha) / math.sqrt(2.0 * math.pi)
        return alpha, density / tail

    def mean(self) -> float:
        """Expected delay (of the truncated distribution for ``normal``)."""
        if self.distribution == 'constant':
            return self.value_s
        if self.distribution == 'uniform':
            return 0.5 * (self.low_s + self.high_s)
        if self.std_s == 0.0:
            return self.mean_s
        _, lam = self._truncation()
        return self.mean_s + self.std_s * lam

    def std(self) -> float:
        """Standard deviation of the delay (of the truncated distribution for ``normal``)."""
        if self.distribution == 'constant':
            return 0.0
        if self.distribution == 'uniform':
            return (self.high_s - self.low_s) / math.sqrt(12.0)
        if self.std_s == 0.0:
            return 0.0
        alpha, lam = self._truncation()
        return self.std_s * math.sqrt(1.0 + alpha * lam - lam * lam)


class LinkModel:
    """Delay and loss of one message on one link; draws come from one seeded generator."""

    def __init__(self, delay: DelayDistribution, loss_probability: float = 0.0, seed: int | None = None):
        if isinstance(loss_probability, bool) or not isinstance(loss_probability, (int, float)) \
                or not 0.0 <= float(loss_probability) <= 1.0:
            raise ConfigError(f'link.loss_probability: must be a number in [0, 1] (got {loss_probability!r})')
        if seed is not None and (isinstance(seed, bool) or not isinstance(seed, int) or seed < 0):
            raise ConfigError(f'link.seed: must be an integer >= 0 or null (got {seed!r})')
        self.delay = delay
        self.loss_probability = float(loss_probability)
        self.seed = seed
        self._rng = np.random.default_rng(seed)

    @classmethod
    def preset(cls, name: str, *, loss_probability: float | None = None, seed: int | None = None) -> 'LinkModel':
        data: dict[str, Any] = {'preset': name, 'seed': seed}
        if loss_probability is not None:
            data['loss_probability'] = loss_probability
        return cls.from_dict(data)

    @classmethod
    def from_dict(cls, data: Any, path: str = 'link') -> 'LinkModel':
        """A validated link model; ``preset`` gives defaults that the other fields override."""
        section = Fields(data, path, ('preset', 'delay', 'loss_probability', 'seed'), error=ConfigError)
        base: Mapping[str, Any] = {}
        if 'preset' in section.data:
            name = section.string('preset', allow_empty=True)
            if name not in PRESETS:
                raise ConfigError(f"{section.path_of('preset')}: unknown preset '{name}' (known: {', '.join(sorted(PRESETS))})")
            base = PRESETS[name]
        if 'delay' in section.data:
            delay = DelayDistribution.from_dict(section.raw('delay'), section.path_of('delay'))
        elif base:
            delay = DelayDistribution.from_dict(base['delay'], section.path_of('delay'))
        else:
            raise ConfigError(f"{section.path_of('delay')}: missing required field (or give a preset: "
                              f"{', '.join(sorted(PRESETS))})")
        loss = section.raw('loss_probability', base.get('loss_probability', 0.0))
        if isinstance(loss, bool) or not isinstance(loss, (int, float)) or not 0.0 <= float(loss) <= 1.0:
            raise ConfigError(f"{section.path_of('loss_probability')}: must be a number in [0, 1] "
                              f"(got {describe_type(loss)} {loss!r})")
        seed = section.raw('seed', None)
        if seed is not None and (isinstance(seed, bool) or not isinstance(seed, int) or seed < 0):
            raise ConfigError(f"{section.path_of('seed')}: must be an integer >= 0 or null (got {describe_type(seed)} {seed!r})")
        return cls(delay, float(loss), seed)

    def to_dict(self) -> dict:
        return {'delay': self.delay.to_dict(), 'loss_probability': self.loss_probability, 'seed': self.seed}

    def sample(self) -> tuple[bool, float]:
        """(delivered, delay in seconds) of one message; the delay is drawn even for a lost
        message so that a run's delays do not depend on which messages were lost."""
        lost = bool(self._rng.random() < self.loss_probability)
        delay = self.delay.sample(self._rng)
        return (not lost, delay)

    def __repr__(self) -> str:
        return f'LinkModel({self.to_dict()!r})'


__all__ = ['DISTRIBUTIONS', 'PRESETS', 'DelayDistribution', 'LinkModel']

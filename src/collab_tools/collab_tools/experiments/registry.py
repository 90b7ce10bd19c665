"""Where ``scripts/experiment`` finds the experiments: each package's ``experiments`` subpackage
lists its :class:`~.api.Experiment` entries in ``EXPERIMENTS`` (light: no experiment code is
imported until one runs)."""
from __future__ import annotations

from importlib import import_module

from .api import Experiment

#: The packages with experiments, in the order the help lists them.
EXPERIMENT_PACKAGES = ('sgcm', 'role_engine', 'coalition_agents')


def all_experiments() -> dict[str, Experiment]:
    """Every experiment by name; a name listed twice is a programming error."""
    found: dict[str, Experiment] = {}
    for package in EXPERIMENT_PACKAGES:
        for experiment in import_module(f'{package}.experiments').EXPERIMENTS:
            if experiment.name in found:
                raise RuntimeError(f'experiment {experiment.name} is listed twice')
            found[experiment.name] = experiment
    return found

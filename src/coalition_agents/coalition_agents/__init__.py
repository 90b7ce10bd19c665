"""Executable coalitions (IQ-ASyMTRe): the pure-Python core lives in :mod:`coalition_agents.core`."""

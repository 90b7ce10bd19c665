"""The nodes' console entry points (``ros2 run <package> <executable>``).

Importing a node's module takes seconds (numpy, scipy, numba kernels, rclpy). Python's default SIGINT
handler raises KeyboardInterrupt wherever the import is, which prints a traceback and ends the process
with -2: a Ctrl-C of the orchestration right after it started its nodes looked like a crash. Until the
module is imported, SIGINT (and SIGTERM) end the process quietly with exit code 0, as a node stopped
while being built does (``node_support.run``); from then on the node's own handling applies. This module
imports nothing heavy, so the window it cannot cover is the interpreter's own start-up (milliseconds).
"""

import importlib
import signal


def _stop_before_start(signum, frame):
    raise SystemExit(0)    # quiet: SystemExit prints nothing


def entry_point(module: str, function: str = 'main'):
    """A console-script target that imports ``module`` with quiet stop signals, then calls its ``function``."""
    def main():
        previous = {sig: signal.signal(sig, _stop_before_start) for sig in (signal.SIGINT, signal.SIGTERM)}
        try:
            target = getattr(importlib.import_module(module), function)
        finally:
            for sig, handler in previous.items():
                signal.signal(sig, handler)
        return target()
    main.__doc__ = f'Run {module}.{function} (signals before it is imported stop quietly).'
    return main


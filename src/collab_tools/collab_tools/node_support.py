"""What the workspace's nodes share: parameter declaration and the main() life cycle.

A node class raises :class:`ConfigurationError` (or the error types passed to :func:`run`)
from its constructor for a bad parameter (exit code 2 with the message), or from a callback for a
setting it can only check later (the same exit code 2). A node that can
end on its own sets ``exit_when_done`` and a ``finished`` Future, so an orchestration
script can wait for it; others spin until shutdown. A node that ended without doing its task
(a leader's perception fault) sets ``exit_code`` (:data:`EXIT_TASK_FAILED`) before finishing.
Malformed messages never end a node: see :mod:`collab_tools.input_guard`.
A node that must finish its work after SIGINT/SIGTERM (the recorder takes what its queues still
hold) is run with ``drain_on_stop``: the signal only asks it to stop, and its ``drain`` method runs
on a live context before the node is destroyed.
"""

import signal
import time

import rclpy
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.signals import SignalHandlerOptions
from rclpy.task import Future

from .core.errors import ConfigurationError  # re-exported: nodes raise it

__all__ = ['ConfigurationError', 'EXIT_TASK_FAILED', 'run', 'stop_signal_handling', 'stop_under_way']

#: Exit code of a node that ended without doing its task (an orchestration session: a failed node).
EXIT_TASK_FAILED = 1


def stop_signal_handling() -> None:
    """Call before destroying executors and nodes at the end of main(): joins rclpy's signal thread.

    Why: on SIGINT/SIGTERM, rclpy's signal thread triggers every executor's SIGINT guard condition
    (read from a list without a lock), then shuts the context down. The woken main thread tears
    down, which frees those guard conditions; a signal thread still in its loop then touches freed
    memory: SIGSEGV (exit -11) at the end of a run on a busy machine.
    ``uninstall_signal_handlers`` joins the thread. A second SIGINT must not break the clean-up."""
    rclpy.uninstall_signal_handlers()
    signal.signal(signal.SIGINT, signal.SIG_IGN)


#: s a stop's context shut-down may lag the error it caused (rclpy's signal thread; a busy machine).
STOP_GRACE_S = 2.0


def stop_under_way(seconds: float = STOP_GRACE_S) -> bool:
    """True once rclpy's context is shut down (a stop under way), waiting up to ``seconds``: whether a
    RuntimeError just caught is part of a stop (see :func:`run`) or an error."""
    deadline = time.monotonic() + seconds
    while rclpy.ok():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.01)
    return True


def _request_stop_on_signals() -> list[int]:
    """SIGINT/SIGTERM append their wall-clock time (ns) to the returned list, once; nothing else."""
    stop_ns: list[int] = []

    def request_stop(_signum, _frame):
        if not stop_ns:
            stop_ns.append(time.time_ns())

    signal.signal(signal.SIGINT, request_stop)
    signal.signal(signal.SIGTERM, request_stop)
    return stop_ns


def _spin_until_signal(node, stop_ns: list[int]) -> None:
    """Spin ``node`` until a signal, then call ``node.drain(executor, stop_ns)`` on the live context
    (``stop_ns``: wall-clock time of the signal). A second signal during the drain is ignored: the
    orchestration escalates to SIGKILL if the drain overruns."""
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    try:
        while not stop_ns and rclpy.ok():
            executor.spin_once(timeout_sec=0.1)  # the Python handler runs between waits
        if stop_ns:
            node.drain(executor, stop_ns[0])
    finally:
        executor.remove_node(node)
        executor.shutdown(timeout_sec=0.0)


def run(node_class, name: str, args=None, config_errors: tuple[type[Exception], ...] = (),
        drain_on_stop: bool = False) -> int:
    """Create the node and spin it until its ``finished`` future (exit_when_done) or shutdown.

    ``drain_on_stop``: rclpy installs no signal handler (its handler shuts the context down at once);
    a signal calls the node's ``drain`` instead (module docstring)."""
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO if drain_on_stop else None)
    stop_ns = _request_stop_on_signals() if drain_on_stop else []  # before the node: no signal is missed
    try:
        node = node_class()
    except (ConfigurationError, ParameterException, *config_errors) as error:
        # ParameterException: rclpy's own type/range check of a start-up value (a string for a double)
        rclpy.logging.get_logger(name).fatal(f'cannot start: {error}')
        rclpy.try_shutdown()
        return 2
    except KeyboardInterrupt:   # SIGINT while the node was being built (a scene loading): a stop, not a crash
        stop_signal_handling()
        rclpy.try_shutdown()
        return 0
    code = 0
    try:
        if getattr(node, 'exit_when_done', False):
            rclpy.spin_until_future_complete(node, node.finished)
            # Give the last messages a moment to reach late subscribers (recorders).
            rclpy.spin_until_future_complete(node, Future(), timeout_sec=0.5)
            code = int(getattr(node, 'exit_code', 0) or 0)
        elif drain_on_stop:
            _spin_until_signal(node, stop_ns)
        else:
            rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except (ConfigurationError, *config_errors) as error:
        # A setting the node can only check once it hears from its team (a role player's limits
        # come with the team description): the same exit 2 as at start.
        rclpy.logging.get_logger(name).fatal(f'cannot start: {error}')
        code = 2
    except RuntimeError:
        # SIGINT shuts the context down from rclpy's signal thread, a moment later: a timer publishing
        # then fails (RCLError "publisher's context is invalid"), and the KeyboardInterrupt the signal
        # also raises can land inside a message's conversion in take_message, which pybind11 reports as
        # RuntimeError ("Unable to convert call argument"). Only an error with no stop under way is one.
        if not stop_under_way():
            raise
    finally:
        stop_signal_handling()
        node.destroy_node()
        rclpy.try_shutdown()
    return code

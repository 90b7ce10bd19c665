"""Taking a subscription's queued messages directly, without the executor.

Why: rclpy's executor pays for one wait set, task and coroutine per message, several times what a
raw message costs to write; a recorder behind a flood takes the queue in batches instead
(and drains or counts it after a stop). Uses the subscription's handle as the executor does
(rclpy.executors.Executor._take_subscription)."""
import time
from collections.abc import Iterator

from .core.recording_loss import DrainRule

__all__ = ['count_published_before', 'take_queued']


def take_queued(subscription, limit: int | None = None) -> Iterator[tuple]:
    """(message, info) pairs taken from ``subscription`` until its queue is empty or ``limit`` are taken;
    the message is bytes for a raw subscription, info the dict a callback with message info gets."""
    count = 0
    with subscription.handle:
        while limit is None or count < limit:
            taken = subscription.handle.take_message(subscription.msg_type, subscription.raw)
            if taken is None:
                return
            count += 1
            yield taken


def count_published_before(subscriptions: dict, stop_ns: int, quiet_period: float, bound: float) -> dict[str, int]:
    """Per key of ``subscriptions``, the messages published before ``stop_ns`` (wall clock, ns) taken from
    its queue, not kept, until none came for ``quiet_period`` s; at most ``bound`` s (then: at least that many).
    Only the keys that had some."""
    counts = dict.fromkeys(subscriptions, 0)
    rule = DrainRule(quiet_period, bound, time.monotonic())
    while not rule.done(time.monotonic()):
        for key, subscription in subscriptions.items():
            for _, info in take_queued(subscription):
                if info.get('source_timestamp', 0) <= stop_ns:
                    counts[key] += 1
                    rule.took(time.monotonic())
        time.sleep(0.01)
    return {key: n for key, n in counts.items() if n}

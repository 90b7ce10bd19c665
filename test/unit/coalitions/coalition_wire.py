"""The in-memory transport the SchemaAgent unit tests share: lossless, FIFO, no ROS."""
from __future__ import annotations

import collections


class Wire:
    """Delivers the agents' requests and offers in FIFO order and records what they asked for:
    ``switches`` (robot, sensor, active) and ``offers`` (provider, recipient, request, instance,
    cost, members), in order. Robots in ``down`` neither tick, receive nor answer."""

    def __init__(self):
        self.queue = collections.deque()
        self.agents = {}
        self.switches: list[tuple[str, str, bool]] = []
        self.offers: list[tuple] = []
        self.down: set[str] = set()

    def outbox(self, robot):
        wire = self

        class Outbox:
            def set_sensor(self, sensor, active):
                wire.switches.append((robot, sensor, active))

            def send_request(self, request, recipients):
                assert robot not in recipients  # self-requests are served by the agent itself
                wire.queue.extend(('request', recipient, request, robot) for recipient in recipients)

            def send_offer(self, offer, reply_to):
                wire.offers.append((offer.provider, reply_to, str(offer.request), str(offer.instance), offer.cost,
                                    offer.members))
                wire.queue.append(('offer', reply_to, offer, robot))
        return Outbox()

    def deliver(self):
        """Hand every queued message to its recipient; how many there were."""
        delivered = len(self.queue)
        while self.queue:
            kind, recipient, payload, sender = self.queue.popleft()
            if recipient in self.down:
                continue
            if kind == 'request':
                self.agents[recipient].on_request(payload, sender)
            else:
                self.agents[recipient].on_offer(payload)
        return delivered

    def round(self, now):
        """Every running agent ticks, then the messages sent are delivered; how many."""
        for name, agent in self.agents.items():
            if name not in self.down:
                agent.tick(now)
        return self.deliver()

    def run(self, now=0.0, rounds=50):
        """Rounds until no message is left."""
        for _ in range(rounds):
            if not self.round(now):
                return
        raise AssertionError('messages did not stop')

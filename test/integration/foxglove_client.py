"""A minimal client of Foxglove's WebSocket protocol, as the Foxglove app speaks it. The protocol was
published as subprotocol ``foxglove.websocket.v1``; the Foxglove SDK (>= 0.x, and foxglove_bridge >= 3)
accepts only its new name ``foxglove.sdk.v1`` (the same messages), so the client offers both, as the
app does: JSON ``serverInfo`` and ``advertise`` from the server, a JSON ``subscribe``
from the client, then binary *message data* frames (opcode 1, subscription id uint32 LE, log time
uint64 LE ns, payload). Synchronous (websockets' sync client), for tests."""

import json
import struct
import time

from websockets.sync.client import connect

SUBPROTOCOL = 'foxglove.sdk.v1'
SUBPROTOCOLS = [SUBPROTOCOL, 'foxglove.websocket.v1']
MESSAGE_DATA = 0x01


class FoxgloveClient:

    def __init__(self, url: str, timeout: float = 10.0):
        self.url, self.timeout = url, timeout
        self.server_info = None
        self.channels: dict[str, dict] = {}      # topic -> advertised channel
        self.subscriptions: dict[int, str] = {}  # subscription id -> topic
        self.messages: list[tuple[str, int, bytes]] = []  # (topic, log time ns, payload)

    def __enter__(self) -> 'FoxgloveClient':
        deadline = time.monotonic() + self.timeout
        while True:  # the server may still be starting
            self._connection = connect(self.url, subprotocols=SUBPROTOCOLS, open_timeout=2.0, max_size=None,
                                       legacy=False)  # connects on __enter__
            try:
                self.ws = self._connection.__enter__()
                break
            except OSError:
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.2)
        self.subprotocol = self.ws.subprotocol
        return self

    def __exit__(self, *exc) -> None:
        self._connection.__exit__(*exc)

    def _receive(self, timeout: float) -> None:
        frame = self.ws.recv(timeout=timeout)
        if isinstance(frame, str):
            message = json.loads(frame)
            if message['op'] == 'serverInfo':
                self.server_info = message
            elif message['op'] == 'advertise':
                for channel in message['channels']:
                    self.channels[channel['topic']] = channel
            elif message['op'] == 'unadvertise':
                gone = set(message['channelIds'])
                self.channels = {t: c for t, c in self.channels.items() if c['id'] not in gone}
        elif frame and frame[0] == MESSAGE_DATA:
            subscription, log_time = struct.unpack_from('<IQ', frame, 1)
            self.messages.append((self.subscriptions[subscription], log_time, bytes(frame[13:])))

    def pump_until(self, condition, timeout: float) -> bool:
        deadline = time.monotonic() + timeout
        while not condition():
            left = deadline - time.monotonic()
            if left <= 0:
                return False
            try:
                self._receive(min(left, 0.5))
            except TimeoutError:
                continue
        return True

    def subscribe(self, topic: str) -> int:
        subscription = len(self.subscriptions) + 1
        self.subscriptions[subscription] = topic
        self.ws.send(json.dumps({'op': 'subscribe', 'subscriptions': [
            {'id': subscription, 'channelId': self.channels[topic]['id']}]}))
        return subscription

    def payloads(self, topic: str) -> list[bytes]:
        return [payload for t, _, payload in self.messages if t == topic]

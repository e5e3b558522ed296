"""Fan-out of telemetry and command events to WebSocket clients (event-loop side).

Each client has its own bounded queue; `publish` never waits. A client whose queue fills (it
reads slower than we send) is disconnected with a reason rather than slowing anyone else;
it may reconnect and will get the latest state.
"""

import asyncio
import time
from dataclasses import dataclass, field

CLIENT_BACKLOG = 256  # messages (~5 s at 50 Hz) a client may fall behind before it is dropped


@dataclass(eq=False)
class Subscription:
    queue: asyncio.Queue[str] = field(default_factory=lambda: asyncio.Queue(CLIENT_BACKLOG))
    too_slow: bool = False


class Broadcaster:
    def __init__(self) -> None:
        self._subs: set[Subscription] = set()
        self.dropped_clients = 0

    def subscribe(self) -> Subscription:
        sub = Subscription()
        self._subs.add(sub)
        return sub

    def unsubscribe(self, sub: Subscription) -> None:
        self._subs.discard(sub)

    @property
    def clients(self) -> int:
        return len(self._subs)

    def publish(self, text: str) -> None:
        for sub in self._subs:
            if sub.too_slow:
                continue
            try:
                sub.queue.put_nowait(text)
            except asyncio.QueueFull:
                sub.too_slow = True
                self.dropped_clients += 1


def stamped(text: str) -> str:
    """A message (a JSON object's text) with `sent_at`, the wall clock now, added as it leaves."""
    return f'{text[:-1]}, "sent_at": {time.time():.6f}}}'

"""Fan-out of telemetry and command events to WebSocket clients (event-loop side).

Each client has its own outbox (ptwl/guard/outbox.py, the same rule as the link's): `publish` never
waits; a state waiting for a slow reader is replaced by the newer one; a client that falls more
than EVENT_BACKLOG events behind is closed with 1013 rather than slowing anyone else, and may
reconnect for the latest state.
"""

import time

from ptwl.guard.outbox import Outbox


class Broadcaster:
    def __init__(self) -> None:
        self._subs: set[Outbox] = set()

    def subscribe(self) -> Outbox:
        sub = Outbox()
        self._subs.add(sub)
        return sub

    def unsubscribe(self, sub: Outbox) -> None:
        self._subs.discard(sub)

    @property
    def clients(self) -> int:
        return len(self._subs)

    def publish(self, text: str) -> None:
        for sub in self._subs:
            sub.put(text)


def stamped(text: str, extra: str = "") -> str:
    """A message (a JSON object's text) with `sent_at`, the wall clock now, added as it leaves
    (and `extra` fields, `, "name": value` text)."""
    return f'{text[:-1]}{extra}, "sent_at": {time.time():.6f}}}'

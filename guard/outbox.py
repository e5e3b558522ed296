"""One WebSocket client's messages waiting to be sent: the rule for every telemetry socket (the
robot's and the link's), so a client that cannot keep up costs a stated amount of memory.

- **States are replaced.** At most one state waits: a newer one takes its place (and its turn,
  after any event that came between), so a reader that falls behind gets the latest state, not a
  backlog of old ones, and is never cut for being slow at states alone.
- **Events are never dropped silently.** Command events and frames changes wait in order; when
  more than `backlog` of them wait, the client is marked too slow and its socket is closed with
  1013 (try again later): it reconnects and re-reads what it missed (the console does, from
  GET /api/commands and /api/frames).

So a client holds at most `backlog` events plus one state, whatever it does.
"""

import asyncio
from collections import deque
from dataclasses import dataclass

EVENT_BACKLOG = 256  # events a client may fall behind (minutes of commands) before it is closed
CLOSE_TOO_SLOW = 1013  # "try again later"
STATE_PREFIX = '{"type": "state"'  # how a state message begins (json.dumps, type first)


def is_state(message: object) -> bool:
    return isinstance(message, str) and message.startswith(STATE_PREFIX)


@dataclass(frozen=True)
class Close:
    """Close the socket with this code and reason (after what was queued before it)."""

    code: int
    reason: str


Item = str | bytes | Close
GONE = Close(1000, "the client went away")


class Outbox:
    def __init__(self, backlog: int = EVENT_BACKLOG) -> None:
        self._items: deque[Item] = deque()
        self._state_waiting = False
        self._events = 0
        self._backlog = backlog
        self._ready = asyncio.Event()
        self.too_slow = False
        self.gone = False  # the client went away: nothing more to send
        self.replaced = 0  # states replaced before they were sent

    def __len__(self) -> int:
        return len(self._items)

    def put(self, message: Item) -> None:
        """Queue `message` (never waits); a state replaces the one still waiting."""
        if self.too_slow:
            return
        if is_state(message):
            if self._state_waiting:
                self._items.remove(next(m for m in self._items if is_state(m)))
                self.replaced += 1
            self._state_waiting = True
        else:
            self._events += 1
            if self._events > self._backlog:
                self.too_slow = True  # what waits is of no use to a client that must re-read
                self._items.clear()
                message = Close(CLOSE_TOO_SLOW, f"client too slow: fell {self._backlog} events behind")
        self._items.append(message)
        self._ready.set()

    def client_gone(self) -> None:
        """Wake the sender for good: its next `get` is a Close, without waiting."""
        self.gone = True
        self._ready.set()

    async def get(self) -> Item:
        """The next message, waiting for one; a Close means close the socket, send nothing more
        (if `gone`, the socket is closed already)."""
        while not self._items:
            if self.gone:
                return GONE
            self._ready.clear()
            await self._ready.wait()
        message = self._items.popleft()
        if is_state(message):
            self._state_waiting = False
        else:
            self._events -= 1
        return message

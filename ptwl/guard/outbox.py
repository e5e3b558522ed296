"""One WebSocket client's messages waiting to be sent: the rule for every telemetry socket (the
robot's and the link's), so a client that cannot keep up costs a stated amount of memory.

- **Old states are dropped.** A state that has waited more than `MAX_STATE_WAIT_S` (2 s) for a
  client is dropped when a newer one comes. A reader with a hiccup loses nothing, and neither
  does one that takes a burst at once (the link releasing what a hold blackout kept); one that
  falls further behind gets recent states, not an ever-older backlog, and is never cut for
  being slow at states alone.
- **Events are never dropped silently.** Command events and frames changes wait in order; when
  more than `backlog` of them wait, the client is marked too slow and its socket is closed with
  1013 (try again later): it reconnects and re-reads what it missed (the console does, from
  GET /api/commands and /api/frames).

- **States within the link's rate.** On a socket the link has told its downlink rate, a state
  is queued only if the states before it used at most `STATE_SHARE` of that rate: a 2 kB/s
  link gets ~1 state a second, the newest, not a queue the link must throw away.

So a client holds at most `backlog` events and the states of the last 2 s (100 at 50 Hz; the
robot's rate is at most 500 Hz; a burst the link releases at once is bounded by its own buffer).
"""

import asyncio
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import TypeGuard

EVENT_BACKLOG = 256  # events a client may fall behind (minutes of commands) before it is closed
MAX_STATE_WAIT_S = 2.0  # a state waiting longer for a client is dropped when a newer one comes
CLOSE_TOO_SLOW = 1013  # "try again later"
# Of a downlink the link tells (ptwl/guard/link_notice.py), the share states may use: the rest
# carries events, HTTP replies and other clients' traffic without a queue behind states.
STATE_SHARE = 0.5
STATE_PREFIX = '{"type": "state"'  # how a state message begins (json.dumps, type first)


def is_state(message: object) -> TypeGuard[str]:
    return isinstance(message, str) and message.startswith(STATE_PREFIX)


@dataclass(frozen=True)
class Close:
    """Close the socket with this code and reason (after what was queued before it)."""

    code: int
    reason: str


Item = str | bytes | Close
GONE = Close(1000, "the client went away")


class Outbox:
    def __init__(self, backlog: int = EVENT_BACKLOG, clock: Callable[[], float] = time.monotonic) -> None:
        self._items: deque[Item] = deque()
        self._state_times: deque[float] = deque()  # [s] when each waiting state came, oldest first
        self._events = 0
        self._backlog = backlog
        self._clock = clock
        self._ready = asyncio.Event()
        self.too_slow = False
        self.gone = False  # the client went away: nothing more to send
        self.replaced = 0  # states dropped for newer ones before they were sent
        self.thinned = 0  # states not queued to keep within the link's downlink
        self._downlink: float | None = None  # [bytes/s] the link's told share (None: unlimited)
        self._next_state_at = 0.0
        self._skipped = 0  # states thinned since the last one queued
        self.state_every_s: float | None = None  # [s] between the states queued, when thinned

    def set_downlink(self, bytes_per_s: float | None) -> None:
        """Send states at most at the rate STATE_SHARE of `bytes_per_s` carries (None: all)."""
        self._downlink = bytes_per_s
        self._next_state_at = 0.0
        if bytes_per_s is None:
            self.state_every_s = None

    def thinning_fields(self) -> str:
        """For the state being sent on a thinned socket: `, "skipped": N, "every_s": T` (the
        states left out before it, and the interval now), so a client counts none of them as
        lost and expects the next state when it will come; "" on a socket sent every state."""
        if self.state_every_s is None:
            return ""
        skipped, self._skipped = self._skipped, 0
        return f', "skipped": {skipped}, "every_s": {self.state_every_s:.6f}'

    def __len__(self) -> int:
        return len(self._items)

    def put(self, message: Item) -> None:
        """Queue `message` (never waits); a state drops those that waited over MAX_STATE_WAIT_S."""
        if self.too_slow:
            return
        if is_state(message):
            now = self._clock()
            if self._downlink is not None:
                if now < self._next_state_at:
                    self.thinned += 1
                    self._skipped += 1
                    return
                self.state_every_s = len(message) / (STATE_SHARE * self._downlink)
                self._next_state_at = now + self.state_every_s
            while self._state_times and now - self._state_times[0] > MAX_STATE_WAIT_S:
                self._state_times.popleft()
                self._items.remove(next(m for m in self._items if is_state(m)))  # the oldest
                self.replaced += 1
            self._state_times.append(now)
        else:
            self._events += 1
            if self._events > self._backlog:
                self.too_slow = True  # what waits is of no use to a client that must re-read
                self._items.clear()
                message = Close(CLOSE_TOO_SLOW, f"client too slow: fell {self._backlog} events behind")
        self._items.append(message)
        self._ready.set()

    def client_gone(self) -> None:
        """Wake the sender for good: its next `get` is GONE, whatever still waits."""
        self.gone = True
        self._ready.set()

    async def get(self) -> Item:
        """The next message, waiting for one; a Close means close the socket, send nothing more
        (GONE: the socket is closed already)."""
        while not self._items and not self.gone:
            self._ready.clear()
            await self._ready.wait()
        if self.gone:
            return GONE
        message = self._items.popleft()
        if is_state(message):
            self._state_times.popleft()
        else:
            self._events -= 1
        return message

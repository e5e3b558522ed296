"""Long-polls: who is waiting for which command to finish (event-loop side).

An entry lives exactly as long as someone waits: it goes when the command is done, the wait
runs out or the client disconnects, so nothing per command outlives its record.
"""

import asyncio
from collections.abc import Awaitable, Callable


class Waiters:
    def __init__(self) -> None:
        self._events: dict[int, asyncio.Event] = {}
        self._counts: dict[int, int] = {}

    def __len__(self) -> int:
        """Long-polls open now."""
        return sum(self._counts.values())

    async def until_done(
        self, command_id: int, timeout_s: float, is_done: Callable[[], bool], client_gone: Awaitable[None]
    ) -> None:
        """Return when the command is done, `timeout_s` has passed or the client went away."""
        event = self._events.setdefault(command_id, asyncio.Event())
        self._counts[command_id] = self._counts.get(command_id, 0) + 1
        gone = asyncio.ensure_future(client_gone)
        done = asyncio.ensure_future(event.wait())
        try:
            if not is_done():  # it may have finished before we registered
                await asyncio.wait({done, gone}, timeout=timeout_s, return_when=asyncio.FIRST_COMPLETED)
        finally:
            gone.cancel()
            done.cancel()
            self._counts[command_id] -= 1
            if self._counts[command_id] == 0:
                del self._counts[command_id]
                del self._events[command_id]

    def notify(self, command_id: int) -> None:
        event = self._events.get(command_id)
        if event is not None:
            event.set()

"""Long-poll support: an asyncio.Event per command someone is waiting for (event-loop side)."""

import asyncio


class Waiters:
    def __init__(self) -> None:
        self._events: dict[int, asyncio.Event] = {}

    def event_for(self, command_id: int) -> asyncio.Event:
        return self._events.setdefault(command_id, asyncio.Event())

    def notify(self, command_id: int) -> None:
        event = self._events.pop(command_id, None)
        if event is not None:
            event.set()

"""One commander at a time (teleoperation paper: one operator acts, the others monitor).

Every browser has its own form; only the client holding the seat may send. Taking the seat is
explicit and always allowed (a supervisor can take over); the one who loses it is told. The seat
is released when its holder's browser goes away. STOP is not behind the seat: anyone may stop.
"""

import threading
from collections.abc import Callable

Listener = Callable[[int | None, int | None], None]  # (previous holder, new holder)


class ControlSeat:
    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._holder: int | None = None
        self._listeners: list[Listener] = []

    @property
    def holder(self) -> int | None:
        with self._lock:
            return self._holder

    def holds(self, client_id: int) -> bool:
        with self._lock:
            return self._holder == client_id

    def on_change(self, listener: Listener) -> None:
        self._listeners.append(listener)

    def take(self, client_id: int) -> None:
        self._move(lambda holder: client_id)

    def release(self, client_id: int) -> None:
        """Give the seat up if `client_id` holds it (its browser closed)."""
        self._move(lambda holder: None if holder == client_id else holder)

    def _move(self, rule: Callable[[int | None], int | None]) -> None:
        with self._lock:
            previous = self._holder
            self._holder = rule(previous)
            new = self._holder
        if new != previous:
            for listener in list(self._listeners):
                listener(previous, new)


def operator_name(client_id: int | None) -> str | None:
    return None if client_id is None else f"operator {client_id}"

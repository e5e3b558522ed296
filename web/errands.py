"""Short jobs a room runs off its caller's thread (a re-read of the robot's records, a frames
refetch, a preview, drawing a new scene): each a named thread the room owns, kept until it ends,
joined when the room closes (after close() none starts). The loops are web/worker.py's."""

import threading
from collections.abc import Callable
from typing import Any

JOIN_TIMEOUT_S = 10.0  # an errand waits on at most one HTTP request (the client's timeout)


class Errands:
    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._threads: list[threading.Thread] = []
        self._closed = False

    def run(self, name: str, job: Callable[..., Any], *args: Any) -> bool:
        """Start `job(*args)` on a thread named `name`; False once closed (it does not run)."""
        with self._lock:
            if self._closed:
                return False
            self._threads = [t for t in self._threads if t.is_alive()]
            thread = threading.Thread(target=job, args=args, name=name, daemon=True)
            self._threads.append(thread)
            thread.start()
            return True

    def close(self, timeout_s: float = JOIN_TIMEOUT_S) -> None:
        with self._lock:
            self._closed = True
            threads = list(self._threads)
        for thread in threads:
            if thread is not threading.current_thread():
                thread.join(timeout=timeout_s)

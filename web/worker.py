"""The console's background threads share one lifecycle: `start()`, `close()` (which signals
and joins), `running`. A subclass loops in `_run` until `self._closed` is set."""

import threading


class Worker:
    def __init__(self, name: str, join_timeout_s: float) -> None:
        self._closed = threading.Event()
        self._join_timeout_s = join_timeout_s
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)

    def start(self) -> None:
        self._thread.start()

    def close(self) -> None:
        self._closed.set()
        if self._thread.is_alive():
            self._thread.join(timeout=self._join_timeout_s)

    @property
    def running(self) -> bool:
        return self._thread.is_alive()

    def _run(self) -> None:
        raise NotImplementedError

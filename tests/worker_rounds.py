"""A Worker's `_closed` event driven by the test (web/worker.py): `_run()` called on the test's
thread goes round `n` times, then finds itself closed. No thread, no timing."""

from collections.abc import Callable


class Rounds:
    def __init__(self, n: int, on_wait: Callable[[], None] = lambda: None) -> None:
        self.n, self.on_wait = n, on_wait
        self.waits: list[float] = []  # [s] the timeout of each wait, in order

    def wait(self, timeout: float) -> bool:
        self.waits.append(timeout)
        self.on_wait()
        return len(self.waits) > self.n

    def set(self) -> None:
        pass

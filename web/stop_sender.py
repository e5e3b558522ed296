"""STOP until the robot confirms it.

A STOP the link refused, lost or held past the round trip is not a STOP: the operator sees it in
red, at STOP, and the console sends it again every RETRY_S until one is confirmed (a second STOP
on a stopped robot does nothing, so retrying is safe). Pressing STOP while one is being sent
does not start a second loop: the one running goes on until a STOP is confirmed.

The state (`StopState`) is what the status bar draws; the first confirmed answer goes to
`on_confirmed` (the console marks the aborted and dropped commands at once, so no line keeps
saying "running" about a command STOP ended).
"""

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

from server.models import StopResult

RETRY_S = 1.0  # between a failed attempt and the next
CONFIRM_MARGIN_S = 2.0  # an attempt not answered within the round trip plus this failed
StopPhase = Literal["idle", "pending", "confirmed", "failed"]


@dataclass(frozen=True)
class StopState:
    phase: StopPhase = "idle"
    text: str = ""
    attempts: int = 0  # STOP requests sent in this press (1: no retry yet)


class StopSender:
    def __init__(
        self,
        stop: Callable[[float], StopResult],  # one POST /api/stop with this timeout [s]
        rtt_s: Callable[[], float],
        on_change: Callable[[StopState], None],
        on_confirmed: Callable[[StopResult], None],
        wait: Callable[[float], bool] | None = None,  # sleeps [s]; True: the console closed
        clock: Callable[[], float] = time.time,
    ) -> None:
        self._stop, self._rtt_s = stop, rtt_s
        self._on_change, self._on_confirmed = on_change, on_confirmed
        self._closed = threading.Event()
        self._wait = wait or self._closed.wait
        self._clock = clock
        self._lock = threading.Lock()
        self._thread: threading.Thread | None = None
        self.state = StopState()

    def press(self, who: str) -> None:
        """Send STOP (from a click's thread: the attempts run on their own)."""
        with self._lock:
            if self._thread is not None and self._thread.is_alive():
                return  # already sending: the loop goes on until one is confirmed
            self._thread = threading.Thread(target=self.run, args=(who,), name="ptwl-stop", daemon=True)
            self._thread.start()

    def run(self, who: str) -> None:
        """(its thread; tests call it directly) Attempt until confirmed or closed."""
        sent = time.strftime("%H:%M:%S", time.localtime(self._clock()))
        self._show(StopState("pending", f"STOP sent by {who} at {sent}; waiting for the robot", 1))
        attempt = 1
        while True:
            timeout_s = self._rtt_s() + CONFIRM_MARGIN_S
            try:
                result = self._stop(timeout_s)
            except Exception as err:  # any failure of the request: say it, then try again
                reason = _reason(err)
                self._show(
                    StopState(
                        "failed",
                        f"STOP sent at {sent} NOT CONFIRMED ({reason}): the robot may still be moving"
                        f" · retrying every {RETRY_S:g} s, {attempt} sent",
                        attempt,
                    )
                )
                if self._wait(RETRY_S):
                    return
                attempt += 1
                continue
            aborted = f"#{result.aborted}" if result.aborted is not None else "nothing running"
            tries = "" if attempt == 1 else f" on attempt {attempt}"
            self._on_confirmed(result)
            self._show(
                StopState(
                    "confirmed",
                    f"stopped (sent {sent}{tries}): aborted {aborted}, dropped {len(result.dropped)} queued",
                    attempt,
                )
            )
            return

    def _show(self, state: StopState) -> None:
        self.state = state
        self._on_change(state)

    def close(self) -> None:
        self._closed.set()
        thread = self._thread
        if thread is not None and thread.is_alive():
            thread.join(timeout=2.0)


def _reason(err: Exception) -> str:
    detail = getattr(err, "detail", None)  # RobotError: the link's or robot's own words
    if detail is not None:
        return str(detail)
    if isinstance(err, TimeoutError) or "Timeout" in type(err).__name__:
        return "no answer within the round trip"
    return type(err).__name__

"""What the ground twin (web/twin.py) has heard, from any thread: the robot's latest state and
running command, this console's sends the robot has not started, and STOP.

Not thread-safe: the twin holds its lock around every call."""

from collections import deque
from dataclasses import dataclass
from typing import Any

from web.twin_sim import Sent


@dataclass(frozen=True)
class Heard:
    """What the twin's thread takes for one advance."""

    state: dict[str, Any] | None
    running: dict[str, Any] | None
    sent: list[Sent]  # not started by the robot yet, oldest first
    new: list[Sent]  # sent since the last advance
    resync_due: bool  # restart from `state` now, not at the next RESYNC_S
    reloaded: bool  # the robot's scene was (re)loaded since the last advance: a new layout


class TwinInbox:
    def __init__(self) -> None:
        self.state: dict[str, Any] | None = None  # the latest telemetry state
        self._running: dict[str, Any] | None = None  # the robot's running command's event
        self._sent: list[Sent] = []
        # The sent_at stamps of commands seen running or done: a `running` event can beat its
        # command's 202 across the link, and a command must not be replayed twice meanwhile.
        self._started_stamps: deque[float] = deque(maxlen=256)
        self._new: list[Sent] = []
        self.resync_due = False
        self._reloaded = False
        self.stop_sent_wall: float | None = None  # [s] a STOP sent, not confirmed yet

    def state_arrived(self, state: dict[str, Any]) -> bool:
        """True if the robot's scene was (re)loaded (its sim time went back): restart from it."""
        reloaded = self.state is not None and float(state["sim_time"]) < float(self.state["sim_time"])
        self.resync_due = self.resync_due or reloaded
        self._reloaded = self._reloaded or reloaded
        self.state = state
        return reloaded

    def command_event(self, message: dict[str, Any]) -> None:
        stamp = (message.get("params") or {}).get("sent_at")
        if stamp is not None and message.get("status") in ("running", "done"):
            self._started_stamps.append(float(stamp))
        if message.get("status") == "running":
            self._running = message
        elif self._running is not None and message.get("id") == self._running.get("id"):
            self._running = None

    def sent(self, sent: Sent) -> None:
        self._sent.append(sent)
        self._new.append(sent)

    def stop_sent(self, sent_wall: float) -> None:
        """This console's commands will not run; the robot's running one may, until confirmed."""
        self._sent.clear()
        self._new.clear()
        self.resync_due = True
        self.stop_sent_wall = sent_wall

    def stop_confirmed(self, aborted: int | None) -> None:
        if self._running is not None and self._running.get("id") == aborted:
            self._running = None
        self.stop_sent_wall = None
        self.resync_due = True

    def take(self) -> Heard:
        started = set(self._started_stamps)
        self._sent = [s for s in self._sent if s.pending() and s.sent_wall not in started]
        heard = Heard(self.state, self._running, list(self._sent), self._new, self.resync_due, self._reloaded)
        self._new = []
        self.resync_due = self._reloaded = False
        return heard

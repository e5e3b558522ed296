"""Is telemetry arriving? Judged from the messages themselves, never from the transport alone.

A link in a drop blackout keeps its TCP connection open while it throws every message away: the
transport says "connected" and nothing comes. So the status line says what the stream shows:
"no telemetry for 7.3 s (~365 messages lost)" once nothing has arrived for SILENT_AFTER_S,
counting the robot's own period; and once messages come again, the gap in their sequence numbers
gives the exact count, shown for SHOW_GAP_S.
"""

import threading
from dataclasses import dataclass
from typing import Literal

SILENT_AFTER_S = 1.0  # nothing for this long (a state comes every 20 ms): the stream is silent
SHOW_GAP_S = 30.0  # how long the last gap's exact count stays on the line
PERIOD_SMOOTHING = 0.1  # weight of each new period in its running mean


@dataclass(frozen=True)
class Gap:
    lost: int  # messages, from the sequence numbers around it
    ended_at: float  # [s] Unix time the message after it arrived
    replaced: bool = False  # on a link that replaces waiting states by newer ones: not lost


@dataclass(frozen=True)
class LinkLine:
    level: Literal["fresh", "late", "stale"]  # flowing; flowing after a recent gap; silent or down
    text: str


class TelemetryHealth:
    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._transport_up = False
        self._transport_text = "connecting"
        self._seq: int | None = None
        self._sent_at: float | None = None
        self._arrived: float | None = None
        self.period_s: float | None = None  # [s] between the robot's states, as measured
        self.lost = 0  # messages lost since this console started
        self.last_gap: Gap | None = None
        self.every_s: float | None = None  # [s] the robot's interval on a thinned socket
        self.replaced = 0  # states the link replaced by newer ones (not lost)

    def on_transport(self, up: bool, text: str) -> None:
        with self._lock:
            self._transport_up, self._transport_text = up, text

    def on_state(
        self,
        seq: int,
        sent_at: float,
        arrived: float,
        skipped: int = 0,
        every_s: float | None = None,
        link_replaces: bool = False,
    ) -> int:
        """A state arrived; returns how many the link lost just before it. `skipped`: states the
        robot left out before it on this socket (a narrow downlink's thinning, not a loss);
        `every_s`: its interval between states then (None: every state is sent);
        `link_replaces`: the link holds only the newest state while its downlink is busy or
        closed, so a gap is states replaced, not lost (counted apart)."""
        with self._lock:
            lost = 0
            self.every_s = every_s
            if self._seq is not None and self._sent_at is not None and seq > self._seq:
                lost = max(0, seq - self._seq - 1 - skipped)
                period = (sent_at - self._sent_at) / (seq - self._seq)
                if period > 0:
                    self.period_s = (
                        period
                        if self.period_s is None
                        else self.period_s + PERIOD_SMOOTHING * (period - self.period_s)
                    )
            if lost > 0:
                if link_replaces:
                    self.replaced += lost
                else:
                    self.lost += lost
                self.last_gap = Gap(lost, arrived, link_replaces)
            # A lower seq is a restarted robot counting again: nothing lost, a new origin.
            self._seq, self._sent_at, self._arrived = seq, sent_at, arrived
            return lost

    def silent_s(self, now: float) -> float | None:
        """[s] since the last state arrived; None before the first."""
        with self._lock:
            return None if self._arrived is None else now - self._arrived

    def line(self, rtt_s: float, now: float, out_of_contact: bool = False) -> LinkLine:
        """The link's line of the status bar; `out_of_contact`: the link's schedule has the
        downlink closed now, so silence is expected and nothing is counted lost."""
        with self._lock:
            up, text, arrived = self._transport_up, self._transport_text, self._arrived
            period, gap, lost, every_s = self.period_s, self.last_gap, self.lost, self.every_s
            replaced = self.replaced
        head = f"link round trip {rtt_s:g} s · "
        if not up:
            silent = "" if arrived is None else f" (nothing for {now - arrived:.1f} s)"
            return LinkLine("stale", head + text + silent)
        if arrived is None:
            return LinkLine("stale", head + "connected; no telemetry yet")
        silent_s = now - arrived
        # On a thinned socket the next state is due every_s after the last: silent only past that.
        if out_of_contact:
            return LinkLine("stale", head + f"no telemetry for {silent_s:.1f} s: the link is out of contact")
        if silent_s > SILENT_AFTER_S + (every_s or 0.0):
            sent_every = every_s or period
            missing = f" (~{round(silent_s / sent_every)} messages lost)" if sent_every else ""
            return LinkLine(
                "stale",
                head + f"no telemetry for {silent_s:.1f} s{missing}; the link is connected but silent",
            )
        recent = gap is not None and now - gap.ended_at <= SHOW_GAP_S
        what = "states replaced by newer ones on the link" if gap and gap.replaced else "messages lost"
        after = f" · {gap.lost} {what} in a gap {now - gap.ended_at:.0f} s ago" if recent and gap else ""
        in_all = f"{lost} lost in all" + (f", {replaced} replaced by the link" if replaced else "")
        thinned = f" · states every {every_s:.1f} s (the downlink's rate)" if every_s else ""
        return LinkLine(
            "late" if recent and gap and not gap.replaced else "fresh",  # replaced: nothing missing
            head + f"connected · telemetry flowing ({in_all}){thinned}{after}",
        )

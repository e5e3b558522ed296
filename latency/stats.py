"""Per-direction link statistics: counts, drops, what is held, and measured delays."""

from collections import Counter, deque
from typing import Any

from latency.delay_line import DROP_REASONS, DelayLine, Dropped, Entry

WINDOW = 20_000  # recent releases kept for percentiles


def _percentiles(values: "deque[float]") -> dict[str, float | None]:
    if not values:
        return {"p50": None, "p95": None, "p99": None, "max": None}
    ordered = sorted(values)
    n = len(ordered) - 1
    return {
        "p50": ordered[round(0.50 * n)],
        "p95": ordered[round(0.95 * n)],
        "p99": ordered[round(0.99 * n)],
        "max": ordered[-1],
    }


class DirectionStats:
    def __init__(self) -> None:
        self.arrived = 0
        self.released = 0
        self.dropped: Counter[str] = Counter()
        self.early_releases = 0  # released before release_at: must stay 0
        self.reorderings = 0  # released out of arrival order without the reorder option: must stay 0
        self._last_seq = 0
        self._realized: deque[float] = deque(maxlen=WINDOW)
        self._configured: deque[float] = deque(maxlen=WINDOW)
        self._holding_error: deque[float] = deque(maxlen=WINDOW)

    def on_arrival(self) -> None:
        self.arrived += 1

    def on_drop(self, drop: Dropped) -> None:
        self.dropped[drop.reason] += 1

    def on_release(self, entry: Entry, now: float, reorder_allowed: bool) -> None:
        self.released += 1
        if now < entry.release_at:
            self.early_releases += 1
        if entry.seq < self._last_seq and not reorder_allowed:
            self.reorderings += 1
        self._last_seq = max(self._last_seq, entry.seq)
        self._realized.append(now - entry.arrival)
        self._configured.append(entry.configured_delay)
        self._holding_error.append(now - entry.release_at)

    def snapshot(self, line: DelayLine) -> dict[str, Any]:
        return {
            "arrived": self.arrived,
            "released": self.released,
            "dropped": {reason: self.dropped[reason] for reason in DROP_REASONS},
            "held_now": {
                "messages": line.held_messages,
                "bytes": line.held_bytes,
                "parked_states": line.parked,
            },
            "early_releases": self.early_releases,
            "reorderings": self.reorderings,
            "realized_delay_s": _percentiles(self._realized),
            "configured_delay_s": _percentiles(self._configured),
            # Release time minus scheduled release (>= 0; how late the driver let it go).
            "holding_error_s": _percentiles(self._holding_error),
        }

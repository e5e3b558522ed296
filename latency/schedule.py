"""A link schedule: when the link exists (contact windows per direction), its one-way delay over
time, and each window's rate; in the spirit of ION-DTN's contact plans (`contact`, `range`).

Times are [s] since the profile took effect (as blackouts are), optionally repeating every
`period` (an orbit, a relay's pass cycle). Between contacts a message is held and forwarded at
the next contact (`store`, the default) or lost (`drop`); the delay line applies this
(latency/delay_line.py), and `Plan` answers the questions both it and the console ask.
"""

import bisect
import math
from typing import Annotated, Literal, Self

import numpy as np
from pydantic import Field, model_validator

from latency.fields import MAX_DELAY_S, Seconds, StrictModel
from ptwl.guard.link_notice import MAX_RATE

MAX_PLAN_S = 30 * 86400.0  # [s] a plan spans at most 30 days
MAX_CONTACTS = 10_000
MAX_DELAY_POINTS = 10_000
MAX_SLOT_TRIES = 64  # windows tried for one that a message fits

PlanTime = Annotated[float, Field(ge=0.0, le=MAX_PLAN_S)]
Rate = Annotated[float, Field(gt=0.0, le=MAX_RATE)]
Direction = Literal["uplink", "downlink"]


class Contact(StrictModel):
    """A window in which the link carries messages one way or both."""

    start: PlanTime = Field(description="[s] since the profile took effect (within the period)")
    end: PlanTime = Field(description="[s]; after start")
    direction: Literal["both", "uplink", "downlink"] = Field("both", description="which way it carries")
    rate_bytes_per_s: Rate | None = Field(
        None, description="[bytes/s] this window's rate (null: the profile's rate for the direction)"
    )

    @model_validator(mode="after")
    def _ordered(self) -> Self:
        if self.end <= self.start:
            raise ValueError(f"end ({self.end:g} s) must be after start ({self.start:g} s)")
        return self

    def carries(self, direction: str) -> bool:
        return self.direction in ("both", direction)


class DelayPoint(StrictModel):
    """The one-way delay at one instant; between points it is linear, beyond them held; two
    points at one instant make a step (an ION `range` ending where the next begins)."""

    at: PlanTime = Field(description="[s] since the profile took effect")
    one_way_s: Seconds = Field(description="[s] one-way delay (both directions)")


class Schedule(StrictModel):
    """When the link exists, how long it takes, and how fast it carries."""

    contacts: list[Contact] | None = Field(
        None,
        max_length=MAX_CONTACTS,
        description="windows the link exists in (null: always); overlapping windows of a direction merge",
    )
    delay: list[DelayPoint] = Field(
        default_factory=list,
        max_length=MAX_DELAY_POINTS,
        description="one-way delay over time, piecewise linear (empty: the profile's uplink/downlink)",
    )
    drift_s_per_s: Annotated[float, Field(ge=-1e-3, le=1e-3)] = Field(
        0.0, description="[s/s] added to the profile's uplink/downlink per second (with no `delay` points)"
    )
    period: Annotated[float, Field(gt=0.0, le=MAX_PLAN_S)] | None = Field(
        None, description="[s] the plan repeats every period (null: once; after it, as at its end)"
    )
    mode: Literal["store", "drop"] = Field(
        "store", description="between contacts: store and forward at the next contact, or drop"
    )

    @model_validator(mode="after")
    def _consistent(self) -> Self:
        if self.delay and self.drift_s_per_s != 0.0:
            raise ValueError("give `delay` points or `drift_s_per_s`, not both")
        if self.contacts == []:
            raise ValueError("contacts: an empty list is a link that never exists (null: always in contact)")
        times = [p.at for p in self.delay]
        if times != sorted(times) or any(a == c for a, c in zip(times, times[2:], strict=False)):
            raise ValueError("delay points must be in increasing `at` (two at one instant: a step)")
        if self.period is not None:
            late = [c for c in self.contacts or [] if c.end > self.period]
            if late:
                raise ValueError(f"a contact ends at {late[0].end:g} s, after the period ({self.period:g} s)")
            if self.delay and self.delay[-1].at > self.period:
                raise ValueError(f"a delay point is at {self.delay[-1].at:g} s, after the period")
        return self


def _merged(windows: list[tuple[float, float, float | None]]) -> list[tuple[float, float, float | None]]:
    """Windows sorted by start; overlapping or touching ones of equal rate merged."""
    out: list[tuple[float, float, float | None]] = []
    for start, end, rate in sorted(windows, key=lambda w: w[0]):
        if out and start <= out[-1][1] and rate == out[-1][2]:
            out[-1] = (out[-1][0], max(out[-1][1], end), rate)
        elif out and start < out[-1][1]:
            # Overlap at another rate: the later window takes over from its start.
            prev = out[-1]
            out[-1] = (prev[0], start, prev[2])
            out.append((start, max(end, prev[1]) if rate == prev[2] else end, rate))
        else:
            out.append((start, end, rate))
    return [w for w in out if w[1] > w[0]]


class Plan:
    """One direction's schedule as times on the link's clock (activation + plan time): is the
    link open, when it opens next, how long it takes and how fast it carries at a time."""

    def __init__(
        self,
        schedule: Schedule | None,
        direction: str,
        base_delay_s: float,
        base_rate: float | None,
        activated_at: float,
    ) -> None:
        self.schedule = schedule
        self.base_delay_s = base_delay_s
        self.base_rate = base_rate
        self.t0 = activated_at
        contacts = schedule.contacts if schedule is not None else None
        self.always_open = contacts is None
        windows = _merged(
            [(c.start, c.end, c.rate_bytes_per_s) for c in contacts or [] if c.carries(direction)]
        )
        self._starts = [w[0] for w in windows]
        self._windows = windows
        self.period = schedule.period if schedule is not None else None
        self._delay_at = [p.at for p in schedule.delay] if schedule is not None else []
        self._delay_s = [p.one_way_s for p in schedule.delay] if schedule is not None else []
        self.drift = schedule.drift_s_per_s if schedule is not None else 0.0
        self.mode = schedule.mode if schedule is not None else "store"

    # ------------------------------------------------------------------ contact
    def _cycle(self, t: float) -> tuple[float, float]:
        """(start of t's period on the link clock, t within the plan)."""
        rel = t - self.t0
        if self.period is None or rel < 0.0:
            return self.t0, rel
        k = math.floor(rel / self.period)
        return self.t0 + k * self.period, rel - k * self.period

    def window_at(self, t: float) -> tuple[float, float, float | None] | None:
        """(start, end, rate) on the link clock of the window open at t, or None in a gap.
        Always open: an unbounded window."""
        if self.always_open:
            return (-math.inf, math.inf, self.base_rate)
        base, rel = self._cycle(t)
        i = bisect.bisect_right(self._starts, rel) - 1
        if i >= 0 and rel < self._windows[i][1]:
            start, end, rate = self._windows[i]
            return (base + start, base + end, rate if rate is not None else self.base_rate)
        return None

    def next_open(self, t: float) -> float | None:
        """The earliest time >= t the link is open (None: never again)."""
        if self.always_open or self.window_at(t) is not None:
            return t
        base, rel = self._cycle(t)
        i = bisect.bisect_right(self._starts, rel)
        if i < len(self._starts):
            return base + self._starts[i]
        if self.period is not None and self._starts:
            return base + self.period + self._starts[0]
        return None

    def slot(self, t: float, size: int) -> float | None:
        """The earliest time >= t a message of `size` bytes can start on the wire and be off it
        before its window closes (ION does not begin a bundle its contact cannot finish); a
        message too long for every window goes at the first opening, overrunning it. None: the
        link never opens again."""
        first = start = self.next_open(t)
        for _ in range(MAX_SLOT_TRIES):
            if start is None:
                return None
            rate = self.rate(start)
            close = self.next_close(start) if rate is not None else None
            if rate is None or close is None or start + size / rate <= close:
                return start
            start = self.next_open(close)
        return first

    def next_close(self, t: float) -> float | None:
        """When the window open at t ends (None: it never does, or the link is closed at t)."""
        window = self.window_at(t)
        if window is None or math.isinf(window[1]):
            return None
        end = window[1]
        # A window ending where the next begins (the plan's last and the next period's first) is
        # one window; a plan open all its period never closes.
        for _ in range(len(self._windows) + 1):
            following = self.window_at(end)
            if following is None:
                return end
            end = following[1]
        return None

    def last_close_before(self, t: float) -> float | None:
        """When the link last closed before t, if it is closed at t (None: open, or never was)."""
        if self.window_at(t) is not None or not self._windows:
            return None
        base, rel = self._cycle(t)
        ends = [w[1] for w in self._windows if w[1] <= rel]
        if ends:
            return base + max(ends)
        if self.period is not None and base > self.t0:
            return base - self.period + max(w[1] for w in self._windows)
        return None

    def rate(self, t: float) -> float | None:
        """[bytes/s] at t (None: unlimited)."""
        window = self.window_at(t)
        return window[2] if window is not None else self.base_rate

    # -------------------------------------------------------------------- delay
    def one_way_s(self, t: float) -> float:
        """[s] the one-way delay of a message leaving at t (before jitter)."""
        if not self._delay_at:
            return min(MAX_DELAY_S, max(0.0, self.base_delay_s + self.drift * (t - self.t0)))
        _, rel = self._cycle(t)
        return float(np.interp(rel, self._delay_at, self._delay_s))

    def trend(self, t: float) -> float:
        """[s/s] how fast the one-way delay changes at t."""
        if not self._delay_at:
            return self.drift
        _, rel = self._cycle(t)
        i = bisect.bisect_right(self._delay_at, rel)
        if i == 0 or i == len(self._delay_at):
            return 0.0
        a, b = self._delay_at[i - 1], self._delay_at[i]
        return (self._delay_s[i] - self._delay_s[i - 1]) / (b - a)

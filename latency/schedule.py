"""A link schedule: when the link exists (contact windows per direction), its one-way delay over
time, and each window's rate; in the spirit of ION-DTN's contact plans (`contact`, `range`).

Times are [s] since the profile took effect (as blackouts are), optionally repeating every
`period` (an orbit, a relay's pass cycle). Between contacts a message is held and forwarded at
the next contact (`store`, the default) or lost (`drop`); the delay line applies this
(latency/delay_line.py), and `Plan` answers the questions both it and the console ask.
"""

import bisect
import heapq
import itertools
import math
from typing import Annotated, Literal, Self

import numpy as np
from pydantic import Field, model_validator

from latency.fields import MAX_DELAY_S, Seconds, StrictModel
from ptwl.guard.link_notice import MAX_RATE, MIN_RATE

MAX_PLAN_S = 30 * 86400.0  # [s] a plan spans at most 30 days
MAX_CONTACTS = 10_000
MAX_DELAY_POINTS = 10_000
MAX_SLOT_TRIES = 64  # windows tried for one that a message fits
EDGE_S = 1e-9  # [s] a time this close to a window's edge is at it (rounding of cycle arithmetic)

PlanTime = Annotated[float, Field(ge=0.0, le=MAX_PLAN_S)]
Rate = Annotated[float, Field(ge=MIN_RATE, le=MAX_RATE)]
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
        for direction in ("uplink", "downlink"):
            if self.contacts and not any(c.carries(direction) for c in self.contacts):
                raise ValueError(
                    f"no contact carries the {direction}: it would never open (give it a window, or "
                    "direction = both)"
                )
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


Window = tuple[float, float, float | None]  # (start, end, rate) [s, s, bytes/s] within the plan


def _windows(contacts: list[Contact], direction: str) -> list[Window]:
    """A direction's windows, disjoint and sorted: where contacts overlap, the one listed later
    sets the rate (a plan's exception over its rule); touching pieces of one rate are joined."""
    mine = [(c.start, c.end, c.rate_bytes_per_s, n) for n, c in enumerate(contacts) if c.carries(direction)]
    edges = sorted({t for start, end, _, _ in mine for t in (start, end)})
    by_start = sorted(mine)
    active: list[tuple[int, float, float | None]] = []  # (-listed order, end, rate): a max-heap
    out: list[Window] = []
    k = 0
    for a, b in itertools.pairwise(edges):
        while k < len(by_start) and by_start[k][0] <= a:
            _, end, rate, n = by_start[k]
            heapq.heappush(active, (-n, end, rate))
            k += 1
        while active and active[0][1] <= a:  # ended: let go (only the top matters)
            heapq.heappop(active)
        if not active:
            continue
        rate = active[0][2]
        if out and out[-1][1] == a and out[-1][2] == rate:
            out[-1] = (out[-1][0], b, rate)
        else:
            out.append((a, b, rate))
    return out


def _closes(windows: list[Window], period: float | None) -> list[float | None]:
    """For each window, when the contact it is part of closes, within the plan (beyond `period`
    when it runs on into the next period through touching windows; None: a plan open all its
    period never closes). Walked backwards from a window whose end nothing touches: O(n)."""
    n = len(windows)

    def touches(i: int) -> bool:  # window i runs on into the next (the last into the first)
        if i + 1 < n:
            return windows[i][1] == windows[i + 1][0]
        return period is not None and windows[i][1] == period and windows[0][0] == 0.0

    ends = [i for i in range(n) if not touches(i)]
    if not ends:
        return [None] * n
    closes: list[float | None] = [None] * n
    i = ends[-1]
    closes[i] = windows[i][1]
    for _ in range(n - 1):
        j = (i - 1) % n
        if touches(j):
            after = closes[i]
            assert after is not None
            closes[j] = after + (period if j == n - 1 and period is not None else 0.0)
        else:
            closes[j] = windows[j][1]
        i = j
    return closes


class Plan:
    """One direction's schedule as times on the link's clock (activation + plan time): is the
    link open, when it opens next, how long it takes and how fast it carries at a time.

    A time within EDGE_S of a window's edge counts as at it: a window's end computed on the link
    clock (activation + period x cycles + end) and then located again rounds either way."""

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
        self.period = schedule.period if schedule is not None else None
        self._windows = _windows(contacts or [], direction)
        self._starts = [w[0] for w in self._windows]
        self._closes = _closes(self._windows, self.period)
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
        k = math.floor((rel + EDGE_S) / self.period)
        return self.t0 + k * self.period, max(0.0, rel - k * self.period)

    def _index(self, t: float) -> tuple[float, float, int | None]:
        """(cycle start, t within the plan, the window open at t or None)."""
        base, rel = self._cycle(t)
        i = bisect.bisect_right(self._starts, rel + EDGE_S) - 1
        inside = i >= 0 and rel + EDGE_S < self._windows[i][1]
        return base, rel, i if inside else None

    def window_at(self, t: float) -> Window | None:
        """(start, end, rate) on the link clock of the window open at t, or None in a gap.
        Always open: an unbounded window."""
        if self.always_open:
            return (-math.inf, math.inf, self.base_rate)
        base, _, i = self._index(t)
        if i is None:
            return None
        start, end, rate = self._windows[i]
        return (base + start, base + end, rate if rate is not None else self.base_rate)

    def next_open(self, t: float) -> float | None:
        """The earliest time >= t the link is open (None: never again)."""
        if self.always_open:
            return t
        base, rel, i = self._index(t)
        if i is not None:
            return t
        j = bisect.bisect_right(self._starts, rel + EDGE_S)
        if j < len(self._starts):
            return max(t, base + self._starts[j])
        if self.period is not None and self._starts:
            return max(t, base + self.period + self._starts[0])
        return None

    def next_close(self, t: float) -> float | None:
        """When the contact open at t ends, through windows that touch (None: it never does, or
        the link is closed at t)."""
        if self.always_open:
            return None
        base, _, i = self._index(t)
        if i is None:
            return None
        close = self._closes[i]
        return None if close is None else base + close

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

    def last_close_before(self, t: float) -> float | None:
        """When the link last closed before t, if it is closed at t (None: open, or never was)."""
        if self.always_open or not self._windows:
            return None
        base, rel, i = self._index(t)
        if i is not None:
            return None
        j = bisect.bisect_right(self._starts, rel + EDGE_S) - 1  # the window before the gap
        if j >= 0:
            return base + self._windows[j][1]
        if self.period is not None and base > self.t0:
            return base - self.period + self._windows[-1][1]
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
            drifted = self.base_delay_s + self.drift * (t - self.t0)
            return self.drift if 0.0 < drifted < MAX_DELAY_S else 0.0  # held at a bound
        _, rel = self._cycle(t)
        i = bisect.bisect_right(self._delay_at, rel)
        if i == 0 or i == len(self._delay_at):
            return 0.0
        a, b = self._delay_at[i - 1], self._delay_at[i]
        return (self._delay_s[i] - self._delay_s[i - 1]) / (b - a)

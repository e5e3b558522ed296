"""The link now and next, as the console shows it and plans by: is each direction in contact,
when that changes and for how long, its one-way delay and trend, its rate and what it holds.

Closed means the schedule has no contact or a blackout is on (either kind: a `drop` blackout
closes the link as surely as a `hold` one). Times go out as Unix seconds (the console counts
down from them) and as seconds from now.
"""

import math
from collections.abc import Mapping
from typing import Any

from latency.delay_line import DelayLine, DirectionModel

MAX_LOOKAHEAD_CHANGES = 64  # boundaries walked to find the next change (a blackout inside a gap...)


def is_open(model: DirectionModel, t: float) -> bool:
    return model.plan.window_at(t) is not None and model.blackout_end(t) == t


def _boundaries(model: DirectionModel, t: float) -> list[float]:
    """Instants after t where the link's state may change (a window's or a blackout's edge)."""
    plan = model.plan
    out = []
    if plan.window_at(t) is not None:
        if (close := plan.next_close(t)) is not None:  # through touching windows: one contact
            out.append(close)
    elif (opens := plan.next_open(t)) is not None:
        out.append(opens)
    since = t - model.activated_at
    for blackout in model.profile.blackouts:
        if (end := blackout.end_if_inside(since)) is not None:
            out.append(model.activated_at + end)
        if (start := blackout.next_start(since)) is not None:
            out.append(model.activated_at + start)
    return [b for b in out if t < b < math.inf]


def next_change(model: DirectionModel, t: float) -> float | None:
    """When the link first differs from how it is at t (None: not within the plan's horizon)."""
    now_open = is_open(model, t)
    cursor = t
    for _ in range(MAX_LOOKAHEAD_CHANGES):
        later = _boundaries(model, cursor)
        if not later:
            return None
        cursor = min(later)
        if is_open(model, cursor) != now_open:
            return cursor
    return None


def closed_since(model: DirectionModel, t: float) -> float | None:
    """When the closure covering t began (None: open at t, or it began before the plan)."""
    starts = []
    if model.plan.window_at(t) is None and (closed := model.plan.last_close_before(t)) is not None:
        starts.append(closed)
    since = t - model.activated_at
    for blackout in model.profile.blackouts:
        if (end := blackout.end_if_inside(since)) is not None:
            starts.append(model.activated_at + end - blackout.duration)
    return min(starts) if starts else None


def direction_outlook(model: DirectionModel, line: DelayLine, now: float, now_unix: float) -> dict[str, Any]:
    def unix(t: float | None) -> float | None:
        return None if t is None else now_unix + (t - now)

    plan = model.plan
    open_now = is_open(model, now)
    change = next_change(model, now)
    gap_s = None
    if open_now and change is not None:
        back = next_change(model, change)
        gap_s = None if back is None else back - change
    return {
        "in_contact": open_now,
        "changes_at_unix": unix(change),
        "changes_in_s": None if change is None else change - now,
        "next_gap_s": gap_s,
        "closed_since_unix": None if open_now else unix(closed_since(model, now)),
        "one_way_s": plan.one_way_s(now),
        "trend_s_per_s": plan.trend(now),
        "rate_bytes_per_s": plan.rate(now),
        "mode": plan.mode,
        "held_messages": line.held_messages,
        "parked_states": line.parked,
    }


def link_outlook(
    models: Mapping[str, DirectionModel], lines: Mapping[str, DelayLine], now: float, now_unix: float
) -> dict[str, Any]:
    return {
        "now_unix": now_unix,
        **{d: direction_outlook(models[d], lines[d], now, now_unix) for d in models},
    }

"""The console's plan around the link's schedule: the status bar's countdown line, the loss of
signal the picture greys out for, and, before a Send, whether the command can finish before the
next loss of signal (and the latest start that would).

All from the link's `outlook` (latency/outlook.py, polled by web/link_poller.py with Unix times),
counted down on this console's clock between polls. Pure functions of (outlook, now): testable
without a browser, the same for every desk.
"""

import math
import time
from dataclasses import dataclass
from typing import Any

from robot_sim.behaviors import BehaviorParams
from robot_sim.params import DitherParams, GripperParams, PtwlParams, RweParams


@dataclass(frozen=True)
class DirectionNow:
    """One direction of the link at `now`, counted down from the last poll."""

    in_contact: bool
    changes_at: float | None  # [s] Unix time it opens or closes next (None: not in the plan)
    next_gap_s: float | None  # [s] how long the coming loss of signal lasts (in contact)
    closed_since: float | None  # [s] Unix time it closed (out of contact)
    one_way_s: float
    trend_s_per_s: float
    rate_bytes_per_s: float | None
    held_messages: int


def direction_now(outlook: dict[str, Any], direction: str, now: float) -> DirectionNow:
    """The polled outlook of a direction as of `now`: a change the countdown has passed flips it
    (until the next poll says what came after)."""
    d = outlook[direction]
    in_contact, changes_at = bool(d["in_contact"]), d["changes_at_unix"]
    closed_since = d["closed_since_unix"]
    if changes_at is not None and now >= changes_at:
        in_contact = not in_contact
        closed_since = None if in_contact else changes_at
        changes_at = None if in_contact or d["next_gap_s"] is None else changes_at + d["next_gap_s"]
    trend = float(d["trend_s_per_s"])
    return DirectionNow(
        in_contact,
        changes_at,
        d["next_gap_s"] if in_contact else None,
        closed_since,
        max(0.0, float(d["one_way_s"]) + trend * (now - float(outlook["now_unix"]))),
        trend,
        d["rate_bytes_per_s"],
        int(d["held_messages"]),
    )


def duration_text(seconds: float) -> str:
    """42 s, 6 min 10 s, 2 h 05 min."""
    whole_s = round(max(0.0, seconds))  # first: 59.7 s is "1 min 00 s", never "60 s"
    if whole_s < 60:
        return f"{whole_s} s"
    if whole_s < 3600:
        return f"{whole_s // 60} min {whole_s % 60:02d} s"
    return f"{whole_s // 3600} h {whole_s % 3600 // 60:02d} min"


def clock_text(unix_s: float) -> str:
    return time.strftime("%H:%M:%S", time.localtime(unix_s))


def trend_text(trend_s_per_s: float) -> str:
    if abs(trend_s_per_s) < 1e-9:
        return "steady"
    per_hour_ms = 3.6e6 * trend_s_per_s
    return f"{'rising' if per_hour_ms > 0 else 'falling'} {abs(per_hour_ms):.1f} ms/h"


def rate_text(bytes_per_s: float | None) -> str:
    if bytes_per_s is None:
        return "unlimited"
    return f"{bytes_per_s / 1000:.1f} kB/s" if bytes_per_s >= 1000 else f"{bytes_per_s:.0f} B/s"


@dataclass(frozen=True)
class Signal:
    """Whether the robot can be heard: the downlink. `lost_since`: when it closed (None: in
    contact); `back_at`: the next contact (None: not in the plan)."""

    lost_since: float | None
    back_at: float | None
    los_at: float | None  # in contact: when it is lost next
    los_for_s: float | None  # ... and for how long


def signal(outlook: dict[str, Any], now: float) -> Signal:
    down = direction_now(outlook, "downlink", now)
    if down.in_contact:
        return Signal(None, None, down.changes_at, down.next_gap_s)
    return Signal(down.closed_since or now, down.changes_at, None, None)


def schedule_line(outlook: dict[str, Any], now: float, state_every_s: float | None) -> str:
    """The bar's line: the next change, the delay and its trend, the downlink's rate and the
    state rate it allows."""
    sig = signal(outlook, now)
    up = direction_now(outlook, "uplink", now)
    down = direction_now(outlook, "downlink", now)
    if sig.lost_since is not None:
        back = (
            f"next contact at {clock_text(sig.back_at)} (in {duration_text(sig.back_at - now)})"
            if sig.back_at is not None
            else "no contact in the plan"
        )
        head = f"LOSS OF SIGNAL for {duration_text(now - sig.lost_since)} · {back}"
    elif sig.los_at is not None:
        gap = f" for {duration_text(sig.los_for_s)}" if sig.los_for_s is not None else ""
        lost_in = duration_text(sig.los_at - now)
        head = f"in contact until {clock_text(sig.los_at)} · signal lost in {lost_in}{gap}"
    else:
        head = "in contact (no loss of signal in the plan)"
    if not up.in_contact:
        head += f" · uplink closed: {up.held_messages} held for its next contact"
    delay = f"one way {down.one_way_s:.3f} s, {trend_text(down.trend_s_per_s)}"
    states = f", states every {state_every_s:.1f} s" if state_every_s else ""
    rate = rate_text(down.rate_bytes_per_s) if down.in_contact else "closed"
    return f"{head} · {delay} · downlink {rate}{states}"


def has_schedule(profile: dict[str, Any] | None) -> bool:
    """A link whose contact, delay or rate changes over time, or is limited: the bar shows its line."""
    if profile is None:
        return False
    return bool(
        profile.get("schedule")
        or profile.get("blackouts")
        or profile.get("uplink_bytes_per_s")
        or profile.get("downlink_bytes_per_s")
    )


def link_replaces_states(profile: dict[str, Any] | None) -> bool:
    """Does the link keep only the newest state while its downlink is busy or closed (a rate, a
    contact window's rate, or a store-and-forward schedule: latency/delay_line.py)? Then a gap
    in the states' numbers is states replaced, not lost."""
    if profile is None:
        return False
    schedule = profile.get("schedule") or {}
    contacts = schedule.get("contacts") or []
    return bool(
        profile.get("downlink_bytes_per_s")
        or (contacts and schedule.get("mode", "store") == "store")
        or any(c.get("rate_bytes_per_s") for c in contacts)
    )


# ------------------------------------------------------------------ before a Send


def run_time_s(params: BehaviorParams | GripperParams | Any) -> tuple[float, float] | None:
    """([s] how long a command runs if it goes as asked, the longest it may run), or None when it
    cannot be told (a state machine)."""
    if isinstance(params, PtwlParams | DitherParams):
        assert params.watchdog is not None  # filled in by validation
        return params.duration, params.watchdog
    if isinstance(params, RweParams | GripperParams):
        return params.duration, params.duration
    return None


@dataclass(frozen=True)
class SendPlan:
    """What the link's schedule means for a command sent now."""

    held_until: float | None  # [s] Unix: the link holds it until the uplink's next contact
    ask_first: bool  # say `text` and ask before sending: it may not finish in contact, or be lost
    latest_start: float | None  # [s] Unix: the latest start that still finishes as asked
    los_at: float | None  # [s] Unix: the loss of signal it is judged against
    text: str  # the warning, or "" when none is needed


def _uplink_wait(up: DirectionNow, now: float, command_bytes: int) -> float | None:
    """[s] Unix when the link lets the command go up, if it must wait for a contact: the uplink
    is closed, or closes before the command is off the wire (latency/schedule.py Plan.slot)."""
    if not up.in_contact:
        return up.changes_at if up.changes_at is not None else math.inf
    on_wire_s = command_bytes / up.rate_bytes_per_s if up.rate_bytes_per_s else 0.0
    if up.changes_at is not None and now + on_wire_s > up.changes_at:
        return up.changes_at + up.next_gap_s if up.next_gap_s is not None else math.inf
    return None


def plan_send(
    outlook: dict[str, Any] | None,
    now: float,
    runs_s: tuple[float, float] | None,
    command_bytes: int = 0,
    mode: str = "store",
) -> SendPlan:
    """Can a command sent now finish before the next loss of signal? It needs the uplink's delay
    (after any wait for the uplink's contact), its run, and its report's downlink delay, before
    the downlink closes (the issue's rule: the report is seen on the ground before the loss).
    Judged on its longest run (its watchdog); the latest start is for its run as asked, so a
    command queued behind others does not start too late. `mode`: the schedule's; in `drop` a
    command that must wait for a contact is lost."""
    if outlook is None:
        return SendPlan(None, False, None, None, "")
    up = direction_now(outlook, "uplink", now)
    down = direction_now(outlook, "downlink", now)
    waits_until = _uplink_wait(up, now, command_bytes)
    if waits_until is not None and mode == "drop":
        return SendPlan(
            None,
            True,
            None,
            None,
            "The uplink is closed (or closes before it is sent) and this link drops what waits for a "
            "contact: it will be lost. Send it in the next contact"
            + (f", at {clock_text(waits_until)}." if math.isfinite(waits_until) else "."),
        )
    held = ""
    if waits_until is not None:
        held = (
            f"The link holds it for the uplink's next contact at {clock_text(waits_until)}. "
            if math.isfinite(waits_until)
            else "The uplink has no contact left in the plan: it will not arrive. "
        )
    arrives = (waits_until if waits_until is not None else now) + up.one_way_s
    if not down.in_contact or down.changes_at is None or runs_s is None or arrives >= down.changes_at:
        # No loss of signal ahead in the plan, a run that cannot be told, or one that starts
        # after the next loss (the outlook does not say when the one after that comes).
        return SendPlan(waits_until, False, None, None, held)
    los = down.changes_at
    typical_s, longest_s = runs_s
    if arrives + longest_s + down.one_way_s <= los:
        return SendPlan(waits_until, False, None, los, held)
    latest_start = los - down.one_way_s - typical_s
    text = held + (
        f"It may run {longest_s:.1f} s (its watchdog) + {up.one_way_s:.2f} s up + {down.one_way_s:.2f} s "
        f"for its report; signal is lost in {duration_text(los - now)} (at {clock_text(los)})."
    )
    return SendPlan(waits_until, True, latest_start if latest_start >= arrives else None, los, text)


def sim_time_at(unix_s: float, state: dict[str, Any]) -> float:
    """The robot's sim time at a Unix time, from a state (sim time then, robot clock `sent_at`):
    the robot runs its simulation at real time."""
    return float(state["sim_time"]) + (unix_s - float(state["sent_at"]))

"""The delay line: one FIFO per direction, pure and clock-independent.

A message's way through the link, in order (one rule for the proxy and the simulated link):
    held by a `hold` blackout until it ends (a `drop` blackout loses it);
    waits for the wire: behind the messages ahead of it (each takes size / rate on the wire,
        netem's `rate`), and for a contact it can be sent within, if the schedule has the link
        closed or the window ends before the message would be off the wire (`drop` mode loses
        it instead);
    may be lost (loss process);
    travels the one-way delay at the moment it left (the schedule's, + jitter);
    is released at max(that, the previous release): jitter never reorders (unless the profile
        asks for it), a long delay never lets a later message overtake, nothing leaves early.

A state (a message with a `replace_key`) that would have to wait for the wire (behind others, or
for a contact) is parked instead, one per key, the latest replacing the one before
("superseded"); it takes the wire when the wire is free. So a narrow or closed downlink carries
the newest state, never an ever-growing queue of old ones, while events wait their turn and are
never dropped for states. The caller passes
`now` in; real-time and simulated drivers both use this class unchanged.
"""

import heapq
import random
from collections import deque
from collections.abc import Callable, Hashable
from dataclasses import dataclass, field

from latency.loss import LossProcess
from latency.profile import LinkProfile
from latency.schedule import Plan

DIRECTIONS = ("uplink", "downlink")
# Why a message waited, as its record says (in this order).
WAITS = ("blackout", "queue", "contact_gap", "serialization", "delay", "order")
DROP_REASONS = ("loss", "blackout", "contact_gap", "no_contact", "overflow", "superseded", "gone")


@dataclass(slots=True)
class Entry:
    """A message held in the line."""

    seq: int
    direction: str
    kind: str
    size: int  # [bytes]
    arrival: float  # [s] clock time it entered the link
    release_at: float  # [s] clock time it may leave
    configured_delay: float  # [s] its earliest release - arrival: every wait but the FIFO's order
    version: int  # profile version that delayed it
    deliver: Callable[[], object] | None = field(default=None, repr=False)
    # [s] each part of the wait, by WAITS (only the nonzero ones): what the record calls `why`
    waits: dict[str, float] = field(default_factory=dict)


@dataclass(slots=True, frozen=True)
class Dropped:
    seq: int
    direction: str
    kind: str
    size: int
    arrival: float
    version: int
    reason: str  # one of DROP_REASONS


@dataclass(slots=True)
class Parked:
    """A state waiting for the wire, to be replaced by a newer one of its key."""

    direction: str
    kind: str
    size: int
    arrival: float
    model: "DirectionModel"
    deliver: Callable[[], object] | None
    lossy: bool
    ready: float  # [s] when it may go, past any blackout
    reason: str  # what it waits for: queue | contact_gap


class DirectionModel:
    """How one direction treats messages under one profile version (its own seeded RNGs)."""

    def __init__(self, profile: LinkProfile, direction: str, version: int, activated_at: float) -> None:
        salt = DIRECTIONS.index(direction)
        self.profile = profile
        self.version = version
        self.activated_at = activated_at
        self.base_delay = profile.uplink if direction == "uplink" else profile.downlink
        base_rate = profile.uplink_bytes_per_s if direction == "uplink" else profile.downlink_bytes_per_s
        self.plan = Plan(profile.schedule, direction, self.base_delay, base_rate, activated_at)
        self._jitter_rng = random.Random(profile.jitter.seed * 1_000_003 + salt)
        self._loss = LossProcess(profile.loss, salt)

    def jitter(self) -> float:
        spec = self.profile.jitter
        if spec.distribution == "uniform":
            return self._jitter_rng.uniform(-spec.amount, spec.amount)
        if spec.distribution == "normal":
            return self._jitter_rng.gauss(0.0, spec.amount)
        return 0.0

    def lost(self) -> bool:
        return self._loss.lost()

    def blackout_end(self, now: float) -> float | None:
        """When a message arriving now may go, past any blackout (None: a `drop` blackout loses it)."""
        start = now
        since = now - self.activated_at
        for window in self.profile.blackouts:
            end = window.end_if_inside(since)
            if end is not None:
                if window.mode == "drop":
                    return None
                start = max(start, self.activated_at + end)
        return start


class DelayLine:
    """The FIFO of one direction."""

    def __init__(self, direction: str, on_drop: Callable[[Dropped], None] = lambda _: None) -> None:
        self.direction = direction
        self._on_drop = on_drop
        self._fifo: deque[Entry] = deque()
        self._heap: list[tuple[float, int, Entry]] = []  # only when the profile allows reordering
        self._last_release = float("-inf")
        self._wire_free_at = float("-inf")  # [s] when the message on the wire has left it
        self._parked: dict[Hashable, Parked] = {}  # at most one state per key, oldest first
        self._parked_bytes = 0
        self._seq = 0
        self.held_messages = 0
        self.held_bytes = 0

    def _drop(self, kind: str, size: int, arrival: float, version: int, reason: str) -> Dropped:
        self._seq += 1
        dropped = Dropped(self._seq, self.direction, kind, size, arrival, version, reason)
        self._on_drop(dropped)
        return dropped

    def admit(
        self,
        now: float,
        model: DirectionModel,
        size: int,
        kind: str,
        deliver: Callable[[], object] | None = None,
        lossy: bool = True,
        replace_key: Hashable | None = None,
    ) -> Entry | Dropped | Parked:
        """Take a message arriving now: its entry, why it was dropped, or (a state with a
        `replace_key` that would wait for the wire) parked until the wire is free."""
        self._admit_parked(now)
        profile = model.profile
        held, held_bytes = self.held_messages + len(self._parked), self.held_bytes + self._parked_bytes
        if held >= profile.max_held_messages or held_bytes + size > profile.max_held_bytes:
            return self._drop(kind, size, now, model.version, "overflow")
        ready = model.blackout_end(now)
        if ready is None:
            return self._drop(kind, size, now, model.version, "blackout")
        wire_at = max(ready, self._wire_free_at)
        opens = model.plan.slot(wire_at, size)
        if opens is None:
            return self._drop(kind, size, now, model.version, "no_contact")
        if opens > wire_at and model.plan.mode == "drop":
            return self._drop(kind, size, now, model.version, "contact_gap")
        # A state parks while the wire is busy or the schedule has the link closed; a blackout
        # alone stores it like any message (a blackout is seconds; a pass's gap can be hours,
        # and 50 Hz states held through it would fill the buffer, whose overflow loses events).
        if replace_key is not None and opens > ready:
            reason = "contact_gap" if opens > wire_at else "queue"
            parked = Parked(self.direction, kind, size, now, model, deliver, lossy, ready, reason)
            if replace_key in self._parked:
                before = self._unpark(replace_key)
                self._drop(before.kind, before.size, before.arrival, before.model.version, "superseded")
            self._parked[replace_key] = parked
            self._parked_bytes += size
            return parked
        waits = {"blackout": ready - now, "queue": wire_at - ready, "contact_gap": opens - wire_at}
        return self._enter(now, opens, model, size, kind, deliver, lossy, waits)

    def _enter(
        self,
        arrival: float,
        wire_at: float,
        model: DirectionModel,
        size: int,
        kind: str,
        deliver: Callable[[], object] | None,
        lossy: bool,
        waits: dict[str, float],
    ) -> Entry | Dropped:
        """The message takes the wire at `wire_at`: lost, or scheduled for release."""
        if lossy and model.lost():
            return self._drop(kind, size, arrival, model.version, "loss")
        plan = model.plan
        rate = plan.rate(wire_at)
        on_wire = size / rate if rate is not None else 0.0
        if rate is not None:  # an unlimited wire is never busy
            self._wire_free_at = wire_at + on_wire
        travel = max(0.0, plan.one_way_s(wire_at) + model.jitter())
        earliest = wire_at + on_wire + travel
        self._seq += 1
        entry = Entry(
            self._seq,
            self.direction,
            kind,
            size,
            arrival,
            earliest,
            earliest - arrival,
            model.version,
            deliver,
        )
        if model.profile.reorder:
            heapq.heappush(self._heap, (entry.release_at, entry.seq, entry))
        else:
            # Never before the previous message: order is kept and delays do not pile up
            # (a message only waits for the one ahead if that one leaves later).
            entry.release_at = max(earliest, self._last_release)
            self._last_release = entry.release_at
            self._fifo.append(entry)
        parts = {**waits, "serialization": on_wire, "delay": travel, "order": entry.release_at - earliest}
        entry.waits = {k: parts[k] for k in WAITS if parts.get(k, 0.0) > 0.0}
        self.held_messages += 1
        self.held_bytes += size
        return entry

    # ------------------------------------------------------------------ parked
    def _parked_ready(self) -> float | None:
        """When the oldest parked state may take the wire (None: none parked)."""
        if not self._parked:
            return None
        first = next(iter(self._parked.values()))
        opens = first.model.plan.slot(max(first.ready, self._wire_free_at), first.size)
        return opens if opens is not None else first.arrival  # never again: drop it now

    def _admit_parked(self, now: float) -> None:
        """Put on the wire, oldest first, each parked state whose turn has come by `now`, by the
        rule `admit` applies (its waits split the same way; `drop` mode loses one a gap held)."""
        while (ready := self._parked_ready()) is not None and ready <= now:
            key = next(iter(self._parked))
            p = self._unpark(key)
            wire_at = max(p.ready, self._wire_free_at)
            opens = p.model.plan.slot(wire_at, p.size)
            if opens is None:
                self._drop(p.kind, p.size, p.arrival, p.model.version, "no_contact")
                continue
            if opens > wire_at and p.model.plan.mode == "drop":
                self._drop(p.kind, p.size, p.arrival, p.model.version, "contact_gap")
                continue
            waits = {
                "blackout": p.ready - p.arrival,
                "queue": wire_at - p.ready,
                "contact_gap": opens - wire_at,
            }
            self._enter(p.arrival, opens, p.model, p.size, p.kind, p.deliver, p.lossy, waits)

    def _unpark(self, key: Hashable) -> Parked:
        p = self._parked.pop(key)
        self._parked_bytes -= p.size
        return p

    def forget(self, key: Hashable) -> None:
        """The receiver of `key`'s states went away: its parked state goes (reason `gone`)."""
        if key in self._parked:
            p = self._unpark(key)
            self._drop(p.kind, p.size, p.arrival, p.model.version, "gone")

    def new_profile(self, now: float, model: "DirectionModel") -> None:
        """A new profile takes effect: the wire is free from now (a message the old rate had
        booked far ahead must not hold back the new one's), and parked states go by its rule."""
        self._wire_free_at = min(self._wire_free_at, now)
        for key in list(self._parked):
            p = self._parked[key]
            ready = model.blackout_end(now)
            if ready is None:
                self._unpark(key)
                self._drop(p.kind, p.size, p.arrival, model.version, "blackout")
                continue
            p.model, p.ready = model, ready

    @property
    def parked(self) -> int:
        """States waiting for the wire (at most one per key)."""
        return len(self._parked)

    # ---------------------------------------------------------------- releases
    def next_release(self) -> float | None:
        heads = []
        if self._fifo:
            heads.append(self._fifo[0].release_at)
        if self._heap:
            heads.append(self._heap[0][0])
        if (ready := self._parked_ready()) is not None:
            heads.append(ready)
        return min(heads) if heads else None

    def pop_due(self, now: float) -> list[Entry]:
        """Entries whose release time has come, in release order."""
        self._admit_parked(now)
        due: list[Entry] = []
        fifo, heap = self._fifo, self._heap
        while True:
            head_fifo = fifo[0] if fifo and fifo[0].release_at <= now else None
            head_heap = heap[0][2] if heap and heap[0][0] <= now else None
            if head_fifo is None and head_heap is None:
                break
            if head_heap is None or (head_fifo is not None and head_fifo.release_at <= head_heap.release_at):
                entry = fifo.popleft()
            else:
                entry = heapq.heappop(heap)[2]
            self.held_messages -= 1
            self.held_bytes -= entry.size
            due.append(entry)
        return due

"""The delay line: one FIFO per direction, pure and clock-independent.

A message's release time is max(arrival + delay, previous release): jitter never reorders
(unless the profile asks for it), a long delay never lets a later message overtake, and nothing
is released before its time. The caller passes `now` in; real-time and simulated drivers both
use this class unchanged.
"""

import heapq
import random
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field

from latency.loss import LossProcess
from latency.profile import LinkProfile

DIRECTIONS = ("uplink", "downlink")


@dataclass(slots=True)
class Entry:
    """A message held in the line."""

    seq: int
    direction: str
    kind: str
    size: int  # [bytes]
    arrival: float  # [s] clock time it entered the link
    release_at: float  # [s] clock time it may leave
    configured_delay: float  # [s] delay drawn for it: base + jitter (+ blackout hold)
    version: int  # profile version that delayed it
    deliver: Callable[[], object] | None = field(default=None, repr=False)


@dataclass(slots=True, frozen=True)
class Dropped:
    seq: int
    direction: str
    kind: str
    size: int
    arrival: float
    version: int
    reason: str  # loss | blackout | overflow


class DirectionModel:
    """How one direction treats messages under one profile version (its own seeded RNGs)."""

    def __init__(self, profile: LinkProfile, direction: str, version: int, activated_at: float) -> None:
        salt = DIRECTIONS.index(direction)
        self.profile = profile
        self.version = version
        self.activated_at = activated_at
        self.base_delay = profile.uplink if direction == "uplink" else profile.downlink
        self._jitter_rng = random.Random(profile.jitter.seed * 1_000_003 + salt)
        self._loss = LossProcess(profile.loss, salt)

    def _jitter(self) -> float:
        spec = self.profile.jitter
        if spec.distribution == "uniform":
            return self._jitter_rng.uniform(-spec.amount, spec.amount)
        if spec.distribution == "normal":
            return self._jitter_rng.gauss(0.0, spec.amount)
        return 0.0

    def decide(self, now: float, lossy: bool) -> tuple[float, float] | str:
        """(earliest release, configured delay) for a message arriving now, or a drop reason."""
        start = now
        since = now - self.activated_at
        for window in self.profile.blackouts:
            end = window.end_if_inside(since)
            if end is not None:
                if window.mode == "drop":
                    return "blackout"
                start = max(start, self.activated_at + end)
        if lossy and self._loss.lost():
            return "loss"
        delay = max(0.0, self.base_delay + self._jitter())
        return start + delay, (start - now) + delay


class DelayLine:
    """The FIFO of one direction."""

    def __init__(self, direction: str) -> None:
        self.direction = direction
        self._fifo: deque[Entry] = deque()
        self._heap: list[tuple[float, int, Entry]] = []  # only when the profile allows reordering
        self._last_release = float("-inf")
        self._seq = 0
        self.held_messages = 0
        self.held_bytes = 0

    def admit(
        self,
        now: float,
        model: DirectionModel,
        size: int,
        kind: str,
        deliver: Callable[[], object] | None = None,
        lossy: bool = True,
    ) -> Entry | Dropped:
        self._seq += 1
        profile = model.profile
        if self.held_messages >= profile.max_held_messages or self.held_bytes + size > profile.max_held_bytes:
            return Dropped(self._seq, self.direction, kind, size, now, model.version, "overflow")
        decision = model.decide(now, lossy)
        if isinstance(decision, str):
            return Dropped(self._seq, self.direction, kind, size, now, model.version, decision)
        earliest, configured = decision
        entry = Entry(
            self._seq, self.direction, kind, size, now, earliest, configured, model.version, deliver
        )
        if profile.reorder:
            heapq.heappush(self._heap, (entry.release_at, entry.seq, entry))
        else:
            # Never before the previous message: order is kept and delays do not pile up
            # (a message only waits for the one ahead if that one leaves later).
            entry.release_at = max(earliest, self._last_release)
            self._last_release = entry.release_at
            self._fifo.append(entry)
        self.held_messages += 1
        self.held_bytes += size
        return entry

    def next_release(self) -> float | None:
        heads = []
        if self._fifo:
            heads.append(self._fifo[0].release_at)
        if self._heap:
            heads.append(self._heap[0][0])
        return min(heads) if heads else None

    def pop_due(self, now: float) -> list[Entry]:
        """Entries whose release time has come, in release order."""
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

"""Drivers that release the link's messages: in real time (asyncio) or on a simulated clock."""

import asyncio
import contextlib
from collections.abc import Hashable

from latency.delay_line import DIRECTIONS, Dropped, Entry, Parked
from latency.link import Link
from latency.profile import LinkProfile


class RealTimeDriver:
    """Releases each direction's messages on time in the running asyncio loop.

    The link's clock must be the loop's clock (time.monotonic on Linux).
    """

    def __init__(self, link: Link) -> None:
        self.link = link
        self._wake = {d: asyncio.Event() for d in DIRECTIONS}
        self._tasks: list[asyncio.Task[None]] = []

    def start(self) -> None:
        self._tasks = [asyncio.create_task(self._run(d), name=f"link-{d}") for d in DIRECTIONS]

    async def stop(self) -> None:
        for task in self._tasks:
            task.cancel()
        for task in self._tasks:
            with contextlib.suppress(asyncio.CancelledError):
                await task

    def notify(self, direction: str) -> None:
        """A message was admitted: it may be due before the current wake-up (or the line was empty)."""
        self._wake[direction].set()

    async def _run(self, direction: str) -> None:
        link, wake = self.link, self._wake[direction]
        while True:
            due_at = link.next_release(direction)
            if due_at is None:
                await wake.wait()
                wake.clear()
                continue
            wait = due_at - link.clock()
            if wait > 0.0:
                wake.clear()
                with contextlib.suppress(TimeoutError):
                    await asyncio.wait_for(wake.wait(), wait)
                continue
            link.release_due(direction)


class ManualClock:
    def __init__(self, start: float = 0.0) -> None:
        self.now = start

    def __call__(self) -> float:
        return self.now


class SimulatedLink:
    """The same Link on a simulated clock: feed arrivals, get releases at their exact times.

    For latency sweeps faster than real time; a real-time run of the same arrivals with the same
    profile (and seeds) makes the same decisions and schedules the same release times.
    """

    def __init__(self, profile: LinkProfile, start: float = 0.0, plan_offset_s: float = 0.0) -> None:
        """`plan_offset_s`: how far into its schedule (and blackouts) the link is at `start` (a
        sweep's trials start at seeded points of a pass)."""
        self.clock = ManualClock(start)
        self.link = Link(profile, clock=self.clock, activated_at=start - plan_offset_s)
        self.released: list[tuple[float, Entry]] = []

    def send(
        self, t: float, direction: str, size: int = 100, kind: str = "ws", replace_key: Hashable | None = None
    ) -> Entry | Dropped | Parked:
        """A message enters the link at time t (non-decreasing across calls)."""
        self.advance_to(t)
        return self.link.admit(direction, size, kind, replace_key=replace_key)

    def next_release(self) -> float | None:
        """When the next message in either direction is due, if any is in flight."""
        due = [r for d in DIRECTIONS if (r := self.link.next_release(d)) is not None]
        return min(due) if due else None

    def advance_to(self, t: float) -> None:
        """Release, in time order, everything due up to t."""
        while True:
            due = [(r, d) for d in DIRECTIONS if (r := self.link.next_release(d)) is not None and r <= t]
            if not due:
                break
            release_at, direction = min(due)
            self.clock.now = max(self.clock.now, release_at)
            self.released.extend((self.clock.now, e) for e in self.link.release_due(direction))
        self.clock.now = max(self.clock.now, t)

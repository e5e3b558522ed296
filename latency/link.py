"""The link: two delay lines under one versioned profile, with stats and an optional record.

Changing the profile is atomic (one assignment of a new (profile, version, models) tuple) and
versioned; a message keeps the delay it was given on arrival, and its record names the version.
"""

import time
from collections.abc import Callable, Hashable
from dataclasses import dataclass
from typing import Any

from latency.delay_line import DIRECTIONS, DelayLine, DirectionModel, Dropped, Entry, Parked
from latency.outlook import link_outlook
from latency.profile import LinkProfile
from latency.record import Recorder
from latency.stats import DirectionStats


@dataclass(frozen=True)
class _Active:
    profile: LinkProfile
    version: int
    activated_at: float
    models: dict[str, DirectionModel]


class Link:
    def __init__(
        self,
        profile: LinkProfile,
        clock: Callable[[], float] = time.monotonic,
        recorder: Recorder | None = None,
        activated_at: float | None = None,
    ) -> None:
        """`activated_at`: the clock time the first profile's schedule and blackouts count from
        (None: now)."""
        self.clock = clock
        self.stats = {d: DirectionStats() for d in DIRECTIONS}
        self.recorder = recorder
        self.lines = {d: DelayLine(d, self._dropped) for d in DIRECTIONS}
        self._active = self._activate(profile, 1, activated_at)

    # ------------------------------------------------------------------ profile
    def _activate(self, profile: LinkProfile, version: int, at: float | None = None) -> _Active:
        now = self.clock() if at is None else at
        models = {d: DirectionModel(profile, d, version, now) for d in DIRECTIONS}
        return _Active(profile, version, now, models)

    @property
    def profile(self) -> LinkProfile:
        return self._active.profile

    @property
    def version(self) -> int:
        return self._active.version

    def set_profile(self, profile: LinkProfile) -> int:
        """Take a new profile for messages arriving from now on; returns its version."""
        self._active = active = self._activate(profile, self._active.version + 1)
        for direction, line in self.lines.items():
            line.new_profile(active.activated_at, active.models[direction])
        return active.version

    def forget(self, direction: str, key: Hashable) -> None:
        """A socket closed: its parked state, if any, goes (latency/delay_line.py)."""
        self.lines[direction].forget(key)

    def profile_view(self) -> dict[str, Any]:
        active = self._active
        return {"version": active.version, **active.profile.model_dump()}

    def rate_now(self, direction: str) -> float | None:
        """[bytes/s] the direction's rate now (None: unlimited)."""
        return self._active.models[direction].plan.rate(self.clock())

    def outlook(self, now_unix: float) -> dict[str, Any]:
        """The link now and next, per direction (latency/outlook.py), with Unix times."""
        active = self._active
        return link_outlook(active.models, self.lines, self.clock(), now_unix)

    # ----------------------------------------------------------------- messages
    def _dropped(self, drop: Dropped) -> None:
        self.stats[drop.direction].on_drop(drop)
        if self.recorder is not None:
            self.recorder.dropped(drop)

    def admit(
        self,
        direction: str,
        size: int,
        kind: str,
        deliver: Callable[[], object] | None = None,
        lossy: bool = True,
        replace_key: Hashable | None = None,
    ) -> Entry | Dropped | Parked:
        """A message enters the link now; `replace_key`: it is a state, replaced by a newer one
        of the same key while it waits for the wire (latency/delay_line.py)."""
        active = self._active
        self.stats[direction].on_arrival()
        return self.lines[direction].admit(
            self.clock(), active.models[direction], size, kind, deliver, lossy, replace_key
        )

    def release_due(self, direction: str) -> list[Entry]:
        """Pop what is due now, account for it, and hand each entry to its deliver callback."""
        now = self.clock()
        due = self.lines[direction].pop_due(now)
        stats = self.stats[direction]
        reorder = self._active.profile.reorder
        for entry in due:
            stats.on_release(entry, now, reorder)
            if self.recorder is not None:
                self.recorder.released(entry, now)
            if entry.deliver is not None:
                entry.deliver()
        return due

    def next_release(self, direction: str) -> float | None:
        return self.lines[direction].next_release()

    def stats_view(self) -> dict[str, Any]:
        return {
            "profile_version": self._active.version,
            **{d: self.stats[d].snapshot(self.lines[d]) for d in DIRECTIONS},
        }

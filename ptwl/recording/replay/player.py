"""The playhead: where in the recording we are, whether it moves, and how fast.

Position is log time. While playing it advances at `speed` x the wall clock from the moment it
was last set (an anchor), so it never drifts however often it is read; at the end it stops.
"""

import time
from collections.abc import Callable
from dataclasses import dataclass

SPEEDS = (0.1, 0.25, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0)  # the console offers these
MAX_SPEED = max(SPEEDS)


@dataclass(frozen=True)
class Playhead:
    position_ns: int
    playing: bool
    speed: float


class Player:
    def __init__(self, start_ns: int, end_ns: int, clock: Callable[[], float] = time.monotonic) -> None:
        self.start_ns, self.end_ns = start_ns, end_ns
        self._clock = clock
        self._anchor_ns = start_ns
        self._anchor_wall = clock()
        self._playing = False
        self._speed = 1.0
        self.jumps = 0  # how many times the position was set (a seek): readers start afresh

    def now(self) -> Playhead:
        position = self._anchor_ns
        if self._playing:
            position += int((self._clock() - self._anchor_wall) * self._speed * 1e9)
            if position >= self.end_ns:
                self._anchor(self.end_ns)
                self._playing = False
                position = self.end_ns
        return Playhead(position, self._playing, self._speed)

    def set(
        self, playing: bool | None = None, speed: float | None = None, position_ns: int | None = None
    ) -> Playhead:
        current = self.now()
        self._anchor(current.position_ns)
        if position_ns is not None:
            self._anchor(min(max(position_ns, self.start_ns), self.end_ns))
            self.jumps += 1
        if speed is not None:
            self._speed = speed
        if playing is not None:
            at_end = self._anchor_ns >= self.end_ns
            if playing and at_end:  # play at the end starts over, as a media player does
                self._anchor(self.start_ns)
                self.jumps += 1
            self._playing = playing
        return self.now()

    def _anchor(self, position_ns: int) -> None:
        self._anchor_ns = position_ns
        self._anchor_wall = self._clock()

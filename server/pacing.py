"""Real-time pacing for a Simulation: sim time follows the wall clock.

robot_sim runs as fast as the CPU allows; this paces it. Steps run in small batches and the
loop sleeps until the wall clock catches up, so sim time tracks wall time to within one batch
at any moment and does not drift over long runs (deadlines are absolute, not summed).
If the CPU falls behind by more than MAX_LAG_S, the pacer drops the backlog instead of racing
to catch up, and counts it.
"""

import time
from collections.abc import Callable

from robot_sim.behaviors.base import BehaviorReport
from robot_sim.sim import Simulation

BATCH_S = 0.005  # [s] sim time stepped between clock checks (default)
MAX_LAG_S = 0.25  # [s] behind the wall clock before the backlog is dropped


class RealTimePacer:
    def __init__(
        self,
        sim: Simulation,
        clock: Callable[[], float] = time.monotonic,
        batch_s: float = BATCH_S,
        sleep: Callable[[float], object] = time.sleep,
    ) -> None:
        self.sim = sim
        self._clock = clock
        self._batch_s = batch_s
        self._sleep = sleep
        self._wall0 = clock()
        self._sim0 = sim.time
        self.dropped_s = 0.0  # [s] of sim time skipped because the CPU fell behind

    def rebase(self) -> None:
        """Restart the correspondence (after a scene reset, which sets sim time to 0)."""
        self._wall0 = self._clock()
        self._sim0 = self.sim.time
        self.dropped_s = 0.0

    def lag_s(self) -> float:
        """Wall time minus sim time since the start [s]; positive when the sim is behind."""
        return (self._clock() - self._wall0) - (self.sim.time - self._sim0) - self.dropped_s

    def advance(self, on_report: Callable[[BehaviorReport], None] | None = None) -> None:
        """Step one batch if the sim is due, otherwise sleep until it is."""
        lag = self.lag_s()
        if lag < 0.0:
            self._sleep(min(-lag, self._batch_s))
            return
        if lag > MAX_LAG_S:
            self.dropped_s += lag
        for report in self.sim.run(self._batch_s):
            if on_report is not None:
                on_report(report)

"""The force/torque plots during a replay, from the recording itself (web/replay_record.py):
after a seek, and at the start while paused, nothing else would come to draw them."""

import threading
from collections.abc import Callable

from web.plots import WrenchPlots
from web.replay_record import ReplayRecord


class ReplayPlots:
    def __init__(self, plots: WrenchPlots | None) -> None:
        self._plots = plots
        self.record: ReplayRecord | None = None  # once the console has read the file
        self._lock = threading.RLock()  # filled by one seek (or the first read) at a time

    def read(self, record: ReplayRecord, paused_at_s: Callable[[], float | None]) -> None:
        """The recording is read: from now on a seek fills the plots (after this, never before);
        paused, they show where the playhead stands (`paused_at_s`: None while playing, asked
        under the lock, so a seek meanwhile is not overwritten by an older position)."""
        with self._lock:
            self.record = record
            position_s = paused_at_s()
            if position_s is not None:
                self.fill(position_s)

    def fill(self, position_s: float) -> None:
        """The plots as they were at `position_s`, from the recording."""
        with self._lock:
            record, plots = self.record, self._plots
            if record is None or plots is None:
                return
            window = record.window(position_s, plots.window_s)
            plots.set_thresholds(window.thresholds)
            plots.jump(window.samples, window.marks_s)

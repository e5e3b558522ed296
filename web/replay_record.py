"""The recording a replay plays, read by the console itself: the force/torque before the playhead
(what the plots show after a seek) and when each command ran (the marks on the replay's timeline).

The replay's robot stand-in serves the present only: the state at the playhead, the command records
up to it. `ptwl replay` starts the console beside it, on the same machine and in the same working
directory, so the file it names (GET /_replay `file`) is there to read. The console indexes it once,
in the background (ptwl/recording/replay/timeline.py: bounded memory, ~18 s for an hour of recording),
and decodes only the few hundred states a seek needs.
"""

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ptwl.recording.replay.timeline import Timeline


@dataclass(frozen=True)
class CommandSpan:
    """When a command ran, in [s] from the recording's start (`end_s` None: still running at the
    end of the recording)."""

    number: int  # 1, 2, ... in the order the commands started
    label: str
    start_s: float
    end_s: float | None
    exit: str | None


@dataclass(frozen=True)
class Window:
    """What the plots held at a moment of the recording."""

    samples: list[tuple[float, list[float]]]  # (sim time [s], wrench [N, N m]), oldest first
    marks_s: list[float]  # [s] sim times of command starts and exits among them
    thresholds: tuple[float, float] | None  # the running command's [N], [N m], or None


class ReplayRecord:
    def __init__(self, path: Path) -> None:
        self._timeline = Timeline(path)  # raises RecordingError (a ValueError), OSError
        self.duration_s = self._timeline.duration_s
        self.commands = self._spans()

    def _spans(self) -> list[CommandSpan]:
        timeline = self._timeline
        start_s = timeline.start_ns / 1e9  # log times and a record's times are the robot's clock
        records = [r for r in timeline.commands_at(timeline.end_ns) if r.get("started_at") is not None]
        records.sort(key=lambda r: float(r["started_at"]))
        return [
            CommandSpan(
                number,
                f"{str(r['type']).upper()} #…{int(r['id']) % 10_000:04d}",
                float(r["started_at"]) - start_s,
                float(r["ended_at"]) - start_s if r.get("ended_at") is not None else None,
                r.get("exit"),
            )
            for number, r in enumerate(records, start=1)
        ]

    def window(self, position_s: float, window_s: float) -> Window:
        """The states logged in the `window_s` before `position_s` (1.5 times as much log time:
        sim time may run behind the wall clock), from the last restart of sim time on."""
        timeline = self._timeline
        series = timeline.telemetry
        end_ns = timeline.start_ns + int(position_s * 1e9)
        first = series.where.upto(end_ns - int(1.5 * window_s * 1e9))
        last = series.where.upto(end_ns)
        states = [series.value(i) for i in range(first, last)]
        log_ns = series.times_ns[first:last]
        sim_times = np.array([float(s["sim_time"]) for s in states])
        restarts = np.flatnonzero(np.diff(sim_times) < 0)
        keep = int(restarts[-1]) + 1 if restarts.size else 0
        samples = [(float(s["sim_time"]), [float(v) for v in s["wrench"]]) for s in states[keep:]]
        return Window(samples, self._marks(log_ns[keep:], sim_times[keep:]), self._thresholds(end_ns))

    def _marks(self, log_ns: np.ndarray, sim_times: np.ndarray) -> list[float]:
        """Each start and exit in the window, at the sim time of the state logged just before it
        (as the live console marks the latest state when the event arrives)."""
        if not len(log_ns):
            return []
        start_s = self._timeline.start_ns / 1e9
        events_ns = [
            int((start_s + t) * 1e9) for c in self.commands for t in (c.start_s, c.end_s) if t is not None
        ]
        marks = []
        for ns in events_ns:
            i = int(np.searchsorted(log_ns, ns, side="right")) - 1
            if i >= 0 and ns <= log_ns[-1]:
                marks.append(float(sim_times[i]))
        return sorted(marks)

    def _thresholds(self, end_ns: int) -> tuple[float, float] | None:
        """The running command's thresholds at `end_ns`, by the rule of the live console's plots."""
        for record in self._timeline.commands_at(end_ns):
            params = record.get("params") or {}
            if record["status"] == "running" and "force_threshold" in params:
                return float(params["force_threshold"]), float(params["torque_threshold"])
        return None

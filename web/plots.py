"""Force and torque plots fit for watching a contact task under delay.

- Sim time restarting (a scene reset, a fault reload) clears the plots: old samples never
  stretch the time axis.
- Each axis spans at least +-MIN_FORCE_N / +-MIN_TORQUE_NM, so sensor noise at rest stays noise,
  and always includes the running command's thresholds, drawn as dashed lines.
- With that range, uPlot's own ticks read "-5", "0", "5" (not "0 / -0 / 0" over 1e-17 N of noise).
- Command starts and exits are marked on the time axis; the current values are printed.
- After a replay's seek the plots take the recording's samples up to the new time at once
  (`jump`), and wait for the stream to get there.

A chart's options never change once it is made: viser's client rebuilds the uPlot chart on any
change of `series`, and its effect that keeps the x window relative to the data then reads the new
chart's x scale before uPlot has set it (null, taken as 0 and 1). From then on every update showed
a window about 1 s wide, seconds before the data: axes and no traces (issue 27, the "blank force
plot in contact": the thresholds' lines were shown and hidden through `series`).
"""

import threading
import time
from collections import deque
from typing import Any

import numpy as np
import viser

from web.markup import Markup, add_html, show

MIN_FORCE_N = 5.0
MIN_TORQUE_NM = 0.5
XYZ_COLORS = ("#e03131", "#2f9e44", "#1971c2")
THRESHOLD_COLOR = "#f08c00"
MARK_COLOR = "#495057"
AWAIT_S = 1.0  # [s] after a jump, how long states from before it may still come
AWAIT_SPAN_S = 0.5  # [s] sim time: how far a playing replay's head may move before its first state


def span(values: np.ndarray, minimum: float, threshold: float | None) -> tuple[float, float]:
    """The y range: the data, at least +-minimum, and +-threshold when one applies (10% margin)."""
    finite = values[np.isfinite(values)]
    lo = min(-minimum, float(finite.min()) if finite.size else 0.0)
    hi = max(minimum, float(finite.max()) if finite.size else 0.0)
    if threshold is not None:
        lo, hi = min(lo, -threshold), max(hi, threshold)
    margin = 0.05 * (hi - lo)
    return lo - margin, hi + margin


class XyzPlot:
    """One uPlot: x, y, z components, +-threshold lines and command marks.

    Its series are set once (see the module's doc). Nothing is NaN either: uPlot takes a NaN as a
    value, and one at the start of a series makes the whole scale NaN (a blank plot). So the
    threshold lines are left out of the y range (`auto` off) and, when no threshold applies, drawn
    far outside it, where the plot's clipping hides them; a command mark is a spike of the `cmd`
    series from the bottom of the range to the top."""

    def __init__(self, gui: viser.GuiApi, symbol: str, unit: str, minimum: float) -> None:
        self.symbol, self.unit, self.minimum = symbol, unit, minimum
        series = self._series()
        self.handle = gui.add_uplot(
            (np.zeros(1),) * len(series),
            series,
            scales={"x": {"time": False}},
            legend={"show": False},
            aspect=2.5,
        )
        self.y_range = (-minimum, minimum)

    def _series(self) -> tuple[Any, ...]:
        dashed = {"stroke": THRESHOLD_COLOR, "dash": (6.0, 4.0), "width": 1.5, "auto": False}
        invisible = {"stroke": "rgba(0,0,0,0)", "width": 0}
        return (
            {"label": "t [s]"},
            *(
                {"label": f"{self.symbol}{axis} [{self.unit}]", "stroke": color}
                for axis, color in zip("xyz", XYZ_COLORS, strict=True)
            ),
            {"label": "limit", **dashed},
            {"label": "-limit", **dashed},
            {"label": "cmd", "stroke": MARK_COLOR, "width": 1},
            # Invisible: they hold the autoscaled range open to at least +-minimum.
            {"label": "range", **invisible},
            {"label": "-range", **invisible},
        )

    def show(self, t: np.ndarray, xyz: np.ndarray, threshold: float | None, marks: np.ndarray) -> None:
        """Draw; `marks` holds the sample indices of command starts and exits."""
        self.y_range = span(xyz, self.minimum, threshold)
        lo, hi = self.y_range
        # No threshold: the lines go ten ranges above the top, off the plot (never NaN, never a
        # change of `series`).
        limit = threshold if threshold is not None else hi + 10.0 * (hi - lo)
        spikes = np.full(t.shape, lo)
        spikes[marks] = hi
        self.handle.data = (
            t,
            xyz[0],
            xyz[1],
            xyz[2],
            np.full(t.shape, limit),
            np.full(t.shape, -limit),
            spikes,
            np.full(t.shape, lo),
            np.full(t.shape, hi),
        )


class WrenchPlots:
    """The samples of the last `window_s` of sim time, drawn by `refresh()`. The feed's thread adds
    and refreshes; a replay's seek (another thread) clears and jumps: one lock keeps them apart."""

    def __init__(self, gui: viser.GuiApi, window_s: float) -> None:
        self.window_s = window_s
        self.summary = add_html(gui, Markup('<div id="ptwl-plot" data-samples="0">no force/torque yet</div>'))
        self.force = XyzPlot(gui, "f", "N", MIN_FORCE_N)
        self.torque = XyzPlot(gui, "t", "N m", MIN_TORQUE_NM)
        self._lock = threading.RLock()
        self._samples: deque[tuple[float, ...]] = deque()
        self._marks: deque[float] = deque()  # [s] sim times of command starts and exits
        self.thresholds: tuple[float, float] | None = None
        self.clears = 0
        self.jumps = 0
        self._awaited: tuple[float, float] | None = None  # after a jump: (sim time, monotonic deadline)

    def add(self, sim_time: float, wrench: list[float]) -> None:
        with self._lock:
            if self._awaited is not None and not self._stream_caught_up(sim_time):
                return  # sent before the seek, still on its way: not the new time's
            if self._samples and sim_time < self._samples[-1][0]:
                self._clear()  # sim time restarted: a scene reset or a fault reload
            elif self._samples and sim_time == self._samples[-1][0]:
                return  # the same state again (a paused replay repeats it): nothing new to plot
            self._samples.append((sim_time, *wrench))
            while self._samples[-1][0] - self._samples[0][0] > self.window_s:
                self._samples.popleft()
            while self._marks and self._marks[0] < self._samples[0][0]:
                self._marks.popleft()

    def _stream_caught_up(self, sim_time: float) -> bool:
        """After a jump the stream's first state is the one the jump ended on (a replay sends the
        state at its playhead after a seek); until it comes, or a second passes, nothing is added."""
        assert self._awaited is not None
        awaited_s, deadline = self._awaited
        if awaited_s <= sim_time <= awaited_s + AWAIT_SPAN_S or time.monotonic() > deadline:
            self._awaited = None
            return True
        return False

    def clear(self) -> None:
        with self._lock:
            self._clear()

    def _clear(self) -> None:
        self._samples.clear()
        self._marks.clear()
        self._awaited = None
        self.clears += 1

    def jump(self, samples: list[tuple[float, list[float]]], marks_s: list[float]) -> None:
        """A replay's seek: the plots become the recording's `samples` (sim time, wrench) up to the
        new time and its command marks [s sim time], drawn at once (paused, nothing else comes)."""
        with self._lock:
            self._clear()
            for sim_time, wrench in samples:
                self.add(sim_time, wrench)
            if self._samples:
                self._marks.extend(m for m in sorted(marks_s) if m >= self._samples[0][0])
                self._awaited = (self._samples[-1][0], time.monotonic() + AWAIT_S)
            self.jumps += 1
        self.refresh()

    def mark(self) -> None:
        """A command started or ended now (at the latest sample's time)."""
        with self._lock:
            if self._samples:
                self._marks.append(self._samples[-1][0])

    def set_thresholds(self, thresholds: tuple[float, float] | None) -> None:
        """The running command's force [N] and torque [N m] thresholds, or None."""
        self.thresholds = thresholds

    def refresh(self) -> None:
        with self._lock:  # one drawing at a time: the summary says what the plots were given
            if not self._samples:
                return
            data = np.array(self._samples).T
            t = data[0]
            marks = np.clip(np.searchsorted(t, np.array(self._marks, dtype=float)), 0, len(t) - 1)
            force_limit, torque_limit = self.thresholds if self.thresholds else (None, None)
            self.force.show(t, data[1:4], force_limit, marks)
            self.torque.show(t, data[4:7], torque_limit, marks)
            show(self.summary, self._summary(t, data[1:7, -1]))

    def _summary(self, t: np.ndarray, wrench: np.ndarray) -> Markup:
        """The current values in words, and (data-*) what the plots show, for tests."""
        thresholds = self.thresholds
        f, tau = wrench[0:3], wrench[3:6]
        return Markup(
            '<div id="ptwl-plot" data-samples="{samples}" data-t0="{t0:.3f}" data-t1="{t1:.3f}" '
            'data-clears="{clears}" data-jumps="{jumps}" data-force-range="{lo:.3f},{hi:.3f}" '
            'data-threshold="{threshold}" data-marks="{marks}" data-force="{f_norm:.2f}" '
            'style="font-size:0.85em;font-variant-numeric:tabular-nums">'
            "f ({f[0]:+.2f}, {f[1]:+.2f}, {f[2]:+.2f}) N, |f| {f_norm:.2f} N{f_limit}<br>"
            "τ ({tau[0]:+.3f}, {tau[1]:+.3f}, {tau[2]:+.3f}) N m, |τ| {tau_norm:.3f} N m{t_limit}</div>"
        ).format(
            samples=len(t),
            t0=t[0],
            t1=t[-1],
            clears=self.clears,
            lo=self.force.y_range[0],
            hi=self.force.y_range[1],
            threshold=thresholds[0] if thresholds else "",
            marks=len(self._marks),
            jumps=self.jumps,
            f=f,
            f_norm=np.linalg.norm(f),
            f_limit=f" of {thresholds[0]:g} N limit" if thresholds else "",
            tau=tau,
            tau_norm=np.linalg.norm(tau),
            t_limit=f" of {thresholds[1]:g} N m limit" if thresholds else "",
        )

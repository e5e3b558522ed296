"""Force and torque plots fit for watching a contact task under delay.

- Sim time restarting (a scene reset, a fault reload) clears the plots: old samples never
  stretch the time axis.
- Each axis spans at least +-MIN_FORCE_N / +-MIN_TORQUE_NM, so sensor noise at rest stays noise,
  and always includes the running command's thresholds, drawn as dashed lines.
- With that range, uPlot's own ticks read "-5", "0", "5" (not "0 / -0 / 0" over 1e-17 N of noise).
- Command starts and exits are marked on the time axis; the current values are printed.
"""

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

    uPlot cannot draw NaN gaps sent from here (the whole plot goes blank), so nothing is NaN: the
    threshold lines are hidden through their series' `show` when no threshold applies, and a
    command mark is a spike of the `cmd` series from the bottom of the range to the top."""

    def __init__(self, gui: viser.GuiApi, symbol: str, unit: str, minimum: float) -> None:
        self.symbol, self.unit, self.minimum = symbol, unit, minimum
        empty = np.zeros(1)
        self._limits_shown = False
        series = self._series(False)
        self.handle = gui.add_uplot(
            (empty,) * len(series),
            series,
            scales={"x": {"time": False}},
            legend={"show": False},
            aspect=2.5,
        )
        self.y_range = (-minimum, minimum)

    def _series(self, limits: bool) -> tuple[Any, ...]:
        dashed = {"stroke": THRESHOLD_COLOR, "dash": (6.0, 4.0), "width": 1.5, "show": limits}
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
        if (threshold is not None) != self._limits_shown:
            self._limits_shown = threshold is not None
            self.handle.series = self._series(self._limits_shown)
        limit = np.full(t.shape, threshold if threshold is not None else 0.0)
        spikes = np.full(t.shape, lo)
        spikes[marks] = hi
        self.handle.data = (
            t,
            xyz[0],
            xyz[1],
            xyz[2],
            limit,
            -limit,
            spikes,
            np.full(t.shape, lo),
            np.full(t.shape, hi),
        )


class WrenchPlots:
    def __init__(self, gui: viser.GuiApi, window_s: float) -> None:
        self.window_s = window_s
        self.summary = add_html(gui, Markup('<div id="ptwl-plot" data-samples="0">no force/torque yet</div>'))
        self.force = XyzPlot(gui, "f", "N", MIN_FORCE_N)
        self.torque = XyzPlot(gui, "t", "N m", MIN_TORQUE_NM)
        self._samples: deque[tuple[float, ...]] = deque()
        self._marks: deque[float] = deque()  # [s] sim times of command starts and exits
        self.thresholds: tuple[float, float] | None = None
        self.clears = 0

    def add(self, sim_time: float, wrench: list[float]) -> None:
        if self._samples and sim_time < self._samples[-1][0]:
            self.clear()  # sim time restarted: a scene reset or a fault reload
        elif self._samples and sim_time == self._samples[-1][0]:
            return  # the same state again (a paused replay repeats it): nothing new to plot
        self._samples.append((sim_time, *wrench))
        while self._samples[-1][0] - self._samples[0][0] > self.window_s:
            self._samples.popleft()
        while self._marks and self._marks[0] < self._samples[0][0]:
            self._marks.popleft()

    def clear(self) -> None:
        self._samples.clear()
        self._marks.clear()
        self.clears += 1

    def mark(self) -> None:
        """A command started or ended now (at the latest sample's time)."""
        if self._samples:
            self._marks.append(self._samples[-1][0])

    def set_thresholds(self, thresholds: tuple[float, float] | None) -> None:
        """The running command's force [N] and torque [N m] thresholds, or None."""
        self.thresholds = thresholds

    def refresh(self) -> None:
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
            'data-clears="{clears}" data-force-range="{lo:.3f},{hi:.3f}" data-threshold="{threshold}" '
            'data-marks="{marks}" style="font-size:0.85em;font-variant-numeric:tabular-nums">'
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
            f=f,
            f_norm=np.linalg.norm(f),
            f_limit=f" of {thresholds[0]:g} N limit" if thresholds else "",
            tau=tau,
            tau_norm=np.linalg.norm(tau),
            t_limit=f" of {thresholds[1]:g} N m limit" if thresholds else "",
        )

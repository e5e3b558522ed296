"""How far to trust the ground twin (web/twin.py): its port predictions, kept every RECORD_S of
sim time, each judged when telemetry for the same sim instant arrives a round trip later.

Not thread-safe: the twin holds its lock around every call."""

import bisect
import math
from collections import deque
from typing import Any

import numpy as np

RECORD_S = 0.01  # [s] sim time between recorded predictions
ERROR_WINDOW_S = 5.0  # [s] the readout's max is over this much wall time
MATCH_S = 0.015  # [s] a prediction judges a state within this much sim time of it
KEPT_MAX = 6000  # predictions kept (a minute): plenty to judge by, and a bound


class PredictionJudge:
    def __init__(self) -> None:
        self._times: list[float] = []  # recorded predictions, sim time ascending
        self._ports: list[np.ndarray] = []  # their port positions [m], world frame
        self._errors: deque[tuple[float, float]] = deque()  # (arrival wall [s], |error| [m])

    def forget(self) -> None:
        """A scene (re)loaded: what was predicted for the old one goes, and so does its judgment
        (it said nothing of the new one)."""
        self._times.clear()
        self._ports.clear()
        self._errors.clear()

    def due(self, sim_time: float) -> bool:
        """Is a prediction for `sim_time` to be kept (one every RECORD_S)? Safe to ask without the
        lock: the list read once, whole or emptied."""
        last = self._times[-1:]
        return not last or sim_time >= last[0] + RECORD_S

    def next_due_s(self) -> float:
        """[s] the sim time from which the next prediction is kept (`due`): -inf if none is kept.
        Safe without the lock, as `due` is."""
        last = self._times[-1:]
        return last[0] + RECORD_S if last else -math.inf

    def record(self, sim_time: float, port_position: np.ndarray) -> None:
        self._times.append(sim_time)
        self._ports.append(port_position)
        if len(self._times) > KEPT_MAX:
            del self._times[: KEPT_MAX // 6], self._ports[: KEPT_MAX // 6]

    def judge(self, state: dict[str, Any], arrived_wall: float) -> float | None:
        """|predicted - reported| port position [m] for the state's sim time, if it was
        predicted; kept for ERROR_WINDOW_S of wall time."""
        error = self._error_for(state)
        if error is not None:
            self._errors.append((arrived_wall, error))
        while self._errors and self._errors[0][0] < arrived_wall - ERROR_WINDOW_S:
            self._errors.popleft()
        return error

    def _error_for(self, state: dict[str, Any]) -> float | None:
        t = float(state["sim_time"])
        i = bisect.bisect_left(self._times, t)
        best = min(
            (j for j in (i - 1, i) if 0 <= j < len(self._times)),
            key=lambda j: abs(self._times[j] - t),
            default=None,
        )
        if best is None or abs(self._times[best] - t) > MATCH_S:
            return None
        return float(np.linalg.norm(self._ports[best] - np.asarray(state["port"]["position"])))

    def judged_wall(self) -> float | None:
        """[s] when a prediction was last judged; None: not since the start or a scene reset."""
        return self._errors[-1][0] if self._errors else None

    def summary(self) -> tuple[float, float] | None:
        """(last, max over the last ERROR_WINDOW_S) |prediction error| [m]; None before any."""
        if not self._errors:
            return None
        return self._errors[-1][1], max(e for _, e in self._errors)


def describe_error(summary: tuple[float, float] | None) -> str:
    """How far the twin's port predictions were off (last, 5 s max), in the operator's words."""
    if summary is None:
        return "not judged yet"
    last, worst = (1000.0 * e for e in summary)
    return f"off {last:.1f} mm (max {worst:.1f} over {ERROR_WINDOW_S:g} s)"

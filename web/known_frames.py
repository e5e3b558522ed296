"""The robot's task frames as this console last heard them (GET /api/frames on a scene load, then
its `frames` telemetry messages, and an operator's own edit at once): what the fields offer, the
checks accept and the twin uses."""

import threading
from collections.abc import Callable
from typing import Any

from robot_sim.task_frames import TaskFrames, frames_from_dicts


class KnownFrames:
    def __init__(self, on_change: Callable[[list[dict[str, Any]], TaskFrames], None]) -> None:
        self._lock = threading.RLock()  # the feed's thread and a desk's click may both bring news
        self._heard: list[dict[str, Any]] = []
        self.task_frames = TaskFrames()
        self._on_change = on_change

    def heard(self) -> list[dict[str, Any]]:
        with self._lock:
            return list(self._heard)

    def set(self, frames: list[dict[str, Any]]) -> None:
        """The whole list, as now known; everyone who uses it is told (under the lock: two
        pieces of news cannot reach them in the wrong order)."""
        with self._lock:
            self._heard = frames
            self.task_frames = frames_from_dicts(frames)
            self._on_change(frames, self.task_frames)

    def edited(self, name: str, frame: dict[str, Any] | None) -> None:
        """An operator added (`frame`) or deleted (None) `name`: known at once; the robot's
        `frames` message, which may already have come, confirms it a downlink later."""
        with self._lock:
            heard = [f for f in self._heard if f["name"] != name]
            self.set(heard if frame is None else [*heard, frame])

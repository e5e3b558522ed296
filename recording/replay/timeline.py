"""A recording as the robot looked at any moment: its telemetry, its scene and its commands.

Everything is indexed by log time, so "the state at t" and "what happened between t0 and t1"
are binary searches. What the console reads live (GET /api/state, /api/geometry,
/api/frames, /api/commands and the telemetry stream) is answered from here.
"""

import bisect
import json
from dataclasses import dataclass, field
from typing import Any

from recording import topics
from recording.reader import Recording


@dataclass
class _Series:
    times_ns: list[int] = field(default_factory=list)
    values: list[Any] = field(default_factory=list)

    def add(self, ns: int, value: Any) -> None:
        self.times_ns.append(ns)
        self.values.append(value)

    def at(self, ns: int) -> Any | None:
        """The latest value logged at or before `ns`."""
        i = bisect.bisect_right(self.times_ns, ns)
        return self.values[i - 1] if i else None

    def upto(self, ns: int) -> list[Any]:
        return self.values[: bisect.bisect_right(self.times_ns, ns)]


@dataclass(frozen=True)
class Outgoing:
    """A telemetry-socket message as the robot sent it (JSON text without `sent_at`)."""

    ns: int
    text: str
    is_state: bool


class Timeline:
    def __init__(self, recording: Recording) -> None:
        self.path = recording.path
        self.telemetry = _Series()
        self.geometry = _Series()
        self.tasks = _Series()
        self.commands = _Series()
        self.frames = _Series()
        stream: list[Outgoing] = []
        for m in sorted(recording.messages, key=lambda m: m.log_time_ns):  # stable: file order on ties
            if m.topic == topics.TELEMETRY.name:
                self.telemetry.add(m.log_time_ns, m.value)
                stream.append(Outgoing(m.log_time_ns, json.dumps(m.value), True))
            elif m.topic == topics.COMMANDS.name:
                self.commands.add(m.log_time_ns, m.value)
                stream.append(Outgoing(m.log_time_ns, json.dumps(m.value), False))
            elif m.topic == topics.GEOMETRY.name:
                self.geometry.add(m.log_time_ns, m.value)
            elif m.topic == topics.TASK.name:
                self.tasks.add(m.log_time_ns, m.value)
            elif m.topic == topics.FRAMES.name:
                self.frames.add(m.log_time_ns, m.value)  # the telemetry `frames` message, whole
                stream.append(Outgoing(m.log_time_ns, json.dumps(m.value), False))
        if not self.telemetry.times_ns or not self.geometry.times_ns:
            raise ValueError(
                f"{recording.path}: no robot telemetry or scene in it: not a ptwl session recording"
            )
        self._stream = stream
        self._stream_ns = [o.ns for o in stream]
        self.start_ns = min(self.telemetry.times_ns[0], self.geometry.times_ns[0])
        self.end_ns = max(self._stream_ns[-1], self.geometry.times_ns[-1])

    @property
    def duration_s(self) -> float:
        return (self.end_ns - self.start_ns) / 1e9

    def between(self, after_ns: int, upto_ns: int) -> list[Outgoing]:
        """Messages logged in (after_ns, upto_ns], in order."""
        lo = bisect.bisect_right(self._stream_ns, after_ns)
        hi = bisect.bisect_right(self._stream_ns, upto_ns)
        return self._stream[lo:hi]

    def state_at(self, ns: int) -> dict[str, Any]:
        return self.telemetry.at(ns) or self.telemetry.values[0]

    def geometry_at(self, ns: int) -> dict[str, Any]:
        return self.geometry.at(ns) or self.geometry.values[0]

    def frames_at(self, ns: int) -> list[dict[str, Any]]:
        """The task frames as the robot last announced them (none in a file recorded before
        frames were)."""
        message = self.frames.at(ns)
        return message["frames"] if message is not None else []

    def frames_messages_at(self, ns: int) -> list[str]:
        """The `frames` message, as recorded, that brings a console up to date at `ns` (a seek);
        none before the first (the console keeps what GET /api/frames said)."""
        message = self.frames.at(ns)
        return [json.dumps(message)] if message is not None else []

    def task_at(self, ns: int) -> dict[str, Any] | None:
        return self.tasks.at(ns)

    def commands_at(self, ns: int) -> list[dict[str, Any]]:
        """Every command as GET /api/commands would have listed it at `ns`: its latest status,
        oldest first."""
        latest: dict[int, dict[str, Any]] = {}
        for event in self.commands.upto(ns):
            record = {k: v for k, v in event.items() if k != "behavior"}
            record["type"] = event["behavior"]  # the event names the command's type `behavior`
            latest.pop(event["id"], None)
            latest[event["id"]] = record
        return sorted(latest.values(), key=lambda r: r["id"])

"""Optional per-message record: JSON lines, or MCAP when the file ends in `.mcap`.

JSON lines are line-buffered: each record reaches the file as it is written, so a crash (kill -9)
loses at most the line being written. An MCAP record (ptwl/recording/writer.py, topic
`/link/messages`) loses at most its last chunk, under 1 s. At 2 x 50 Hz telemetry that is ~100
records a second, nothing next to the proxy's own work.
"""

import json
import time
from collections.abc import Callable
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any, Protocol

from latency.delay_line import Dropped, Entry

if TYPE_CHECKING:
    from ptwl.recording.writer import SessionRecorder


def released_fields(entry: Entry, now: float) -> dict[str, Any]:
    return {
        "seq": entry.seq,
        "direction": entry.direction,
        "kind": entry.kind,
        "size": entry.size,
        "arrival": entry.arrival,
        "release": now,
        "scheduled_release": entry.release_at,
        "configured_delay": entry.configured_delay,
        "realized_delay": now - entry.arrival,
        "why": entry.waits,
        "profile_version": entry.version,
        "drop_reason": None,
    }


def dropped_fields(drop: Dropped) -> dict[str, Any]:
    return {
        "seq": drop.seq,
        "direction": drop.direction,
        "kind": drop.kind,
        "size": drop.size,
        "arrival": drop.arrival,
        "release": None,
        "scheduled_release": None,
        "configured_delay": None,
        "realized_delay": None,
        "why": {},
        "profile_version": drop.version,
        "drop_reason": drop.reason,
    }


class Recorder(Protocol):
    def released(self, entry: Entry, now: float) -> None: ...
    def dropped(self, drop: Dropped) -> None: ...
    def close(self) -> None: ...


class JsonLinesRecorder:
    def __init__(self, path: Path) -> None:
        self._file: IO[str] = path.open("a", buffering=1)

    def released(self, entry: Entry, now: float) -> None:
        self._file.write(json.dumps(released_fields(entry, now)) + "\n")

    def dropped(self, drop: Dropped) -> None:
        self._file.write(json.dumps(dropped_fields(drop)) + "\n")

    def close(self) -> None:
        self._file.close()


class McapRecorder:
    """Into a recording's `/link/messages` (ptwl/recording/writer.py's SessionRecorder). `stamp` makes
    a record's log time from the link-clock time it happened (a release, or a drop's arrival):
    the proxy uses the wall clock, so a link file lines up with the robot's recording of the
    same session; a virtual-time trial uses its own clock."""

    def __init__(self, out: "SessionRecorder", stamp: Callable[[float], int]) -> None:
        self._out = out
        self._stamp = stamp

    def released(self, entry: Entry, now: float) -> None:
        self._out.link(released_fields(entry, now), self._stamp(now))

    def dropped(self, drop: Dropped) -> None:
        self._out.link(dropped_fields(drop), self._stamp(drop.arrival))

    def close(self) -> None:
        self._out.close()


def open_recorder(path: Path) -> Recorder:
    if path.suffix != ".mcap":
        return JsonLinesRecorder(path)
    from ptwl.recording.writer import SessionRecorder, versions  # only an MCAP record needs it

    return McapRecorder(
        SessionRecorder(path, {"source": "ptwl proxy", **versions()}), lambda _: time.time_ns()
    )

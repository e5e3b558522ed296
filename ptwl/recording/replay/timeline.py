"""A recording as the robot looked at any moment: its telemetry, its scene and its commands.

Everything is indexed by log time, so "the state at t" and "what happened between t0 and t1"
are binary searches. What the console reads live (GET /api/state, /api/geometry,
/api/frames, /api/commands and the telemetry stream) is answered from here.

Memory stays bounded however long the file: one pass (ptwl/recording/reader.py, its bounds) checks
every message the replay serves and keeps only where each is (log time, the chunk's byte offset
and the message's place in it: 21 B an entry once sorted, 33 B while the pass builds it; states
and frames have two entries, as a series and in the stream; at most MAX_INDEXED). A message is
decoded again from its chunk when it is served; the last CACHED_CHUNKS chunks read stay in
memory (each at most MAX_CHUNK_BYTES decompressed, ~1 MiB as our writer makes them), so playing
reads each chunk once. Command events, which GET /api/commands folds from the start on every
call, are kept decoded, up to MAX_COMMAND_BYTES of their JSON.
"""

import json
import threading
from array import array
from collections import OrderedDict
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, overload

import numpy as np

from ptwl.recording import topics
from ptwl.recording.reader import Located, RecordingError, Scan

MAX_INDEXED = 5_000_000  # messages on the replayed topics (~14 h at 50 Hz): <= ~330 MB of index at its peak
MAX_COMMAND_BYTES = 4 * 2**20  # [B] command events' JSON, kept decoded (~10,000 events, ~50 MB)
CACHED_CHUNKS = 2  # chunks kept decompressed: the one playing and the one before a seek

REPLAYED = (topics.TELEMETRY, topics.COMMANDS, topics.FRAMES, topics.GEOMETRY, topics.TASK)
STREAMED = (topics.TELEMETRY.name, topics.COMMANDS.name, topics.FRAMES.name)  # sent on the socket
# What each replayed message must be for the routes to serve it: an object, with these fields.
_FIELDS: dict[str, dict[str, type | tuple[type, ...]]] = {
    topics.TELEMETRY.name: {"sim_time": (int, float)},
    topics.COMMANDS.name: {"id": int, "behavior": str},
    topics.FRAMES.name: {"frames": list},
    topics.GEOMETRY.name: {},
    topics.TASK.name: {},
}


@dataclass(frozen=True)
class Outgoing:
    """A telemetry-socket message as the robot sent it (JSON text without `sent_at`)."""

    ns: int
    text: str
    is_state: bool


class _Where:
    """Where each message of some topics is, in log-time order (file order on ties)."""

    def __init__(self) -> None:
        self._new_staging()
        self.times_ns = np.zeros(0, np.int64)
        self.offsets = np.zeros(0, np.int64)
        self.ordinals = np.zeros(0, np.int32)
        self.kinds = np.zeros(0, np.int8)  # index into REPLAYED

    def add(self, found: Located, kind: int) -> None:
        self._times.append(found.message.log_time)
        self._offsets.append(found.offset)
        self._ordinals.append(found.ordinal)
        self._order.append(found.number)
        self._topics.append(kind)

    def sort(self) -> None:
        times = np.frombuffer(self._times, np.int64) if self._times else np.zeros(0, np.int64)
        order = np.frombuffer(self._order, np.int64) if self._order else np.zeros(0, np.int64)
        by_time = np.lexsort((order, times))
        self.times_ns = times[by_time]
        self.offsets = np.asarray(self._offsets, np.int64)[by_time]
        self.ordinals = np.asarray(self._ordinals, np.int32)[by_time]
        self.kinds = np.asarray(self._topics, np.int8)[by_time]
        self._new_staging()

    def _new_staging(self) -> None:
        """Empty growable arrays for `add` (compact: 33 B a message until `sort`)."""
        self._times, self._offsets, self._ordinals, self._order = (
            array("q"),
            array("q"),
            array("l"),
            array("q"),
        )
        self._topics = array("b")

    def __len__(self) -> int:
        return len(self.times_ns)

    def upto(self, ns: int) -> int:
        """How many were logged at or before `ns`."""
        return int(np.searchsorted(self.times_ns, ns, side="right"))


class _Values(Sequence[Any]):
    """A series' values, decoded from the file when asked for."""

    def __init__(self, series: "_Series") -> None:
        self._series = series

    def __len__(self) -> int:
        return len(self._series.where)

    @overload
    def __getitem__(self, i: int) -> Any: ...
    @overload
    def __getitem__(self, i: slice) -> list[Any]: ...
    def __getitem__(self, i: int | slice) -> Any:
        if isinstance(i, slice):
            return [self[j] for j in range(*i.indices(len(self)))]
        if not -len(self) <= i < len(self):
            raise IndexError(i)
        return self._series.value(i % len(self))

    def __iter__(self) -> Iterator[Any]:
        return (self[i] for i in range(len(self)))


class _Series:
    def __init__(self, timeline: "Timeline") -> None:
        self.where = _Where()
        self._timeline = timeline

    @property
    def times_ns(self) -> np.ndarray:
        return self.where.times_ns

    @property
    def values(self) -> _Values:
        return _Values(self)

    def value(self, i: int) -> Any:
        return self._timeline._value(int(self.where.offsets[i]), int(self.where.ordinals[i]))

    def at(self, ns: int) -> Any | None:
        """The latest value logged at or before `ns`."""
        i = self.where.upto(ns)
        return self.value(i - 1) if i else None


class Timeline:
    def __init__(self, path: Path) -> None:
        self.path = path
        self._scan = Scan(path, [t.name for t in REPLAYED])
        self._chunks: OrderedDict[int, list[Any]] = OrderedDict()
        self._lock = threading.Lock()  # the chunk cache: routes may run on worker threads
        self.telemetry, self.geometry, self.tasks, self.frames = (_Series(self) for _ in range(4))
        by_topic = {
            topics.TELEMETRY.name: self.telemetry,
            topics.GEOMETRY.name: self.geometry,
            topics.TASK.name: self.tasks,
            topics.FRAMES.name: self.frames,
        }
        kinds = {t.name: i for i, t in enumerate(REPLAYED)}
        self._stream = _Where()
        commands: list[tuple[int, int, dict[str, Any]]] = []  # (ns, file order, event)
        command_bytes = 0
        for indexed, found in enumerate(self._scan.located(), start=1):
            value = self._checked(found)
            topic = found.channel.topic
            if indexed > MAX_INDEXED:
                raise RecordingError(
                    f"{path}: over {MAX_INDEXED} messages to replay: the replay's index is bounded "
                    "(`ptwl report` reads it)"
                )
            if topic == topics.COMMANDS.name:
                command_bytes += len(found.message.data)
                if command_bytes > MAX_COMMAND_BYTES:
                    raise RecordingError(
                        f"{path}: message {found.number} on {topic}: over {MAX_COMMAND_BYTES} B of command "
                        "events, which a replay keeps in memory"
                    )
                commands.append((found.message.log_time, found.number, value))
            else:
                by_topic[topic].where.add(found, kinds[topic])
            if topic in STREAMED:
                self._stream.add(found, kinds[topic])
        for series in by_topic.values():
            series.where.sort()
        self._stream.sort()
        commands.sort(key=lambda c: (c[0], c[1]))
        self._command_ns = np.asarray([c[0] for c in commands], np.int64)
        self._commands = [c[2] for c in commands]
        self.complete, self.problem = self._scan.complete, self._scan.problem
        if not len(self.telemetry.where) or not len(self.geometry.where):
            raise RecordingError(f"{path}: no robot telemetry or scene in it: not a ptwl session recording")
        self.start_ns = int(min(self.telemetry.times_ns[0], self.geometry.times_ns[0]))
        self.end_ns = int(max(self._stream.times_ns[-1], self.geometry.times_ns[-1]))

    @property
    def duration_s(self) -> float:
        return (self.end_ns - self.start_ns) / 1e9

    def between(self, after_ns: int, upto_ns: int) -> list[Outgoing]:
        """Messages logged in (after_ns, upto_ns], in order."""
        stream = self._stream
        lo, hi = stream.upto(after_ns), stream.upto(upto_ns)
        telemetry = REPLAYED.index(topics.TELEMETRY)
        return [
            Outgoing(
                int(stream.times_ns[i]),
                json.dumps(self._value(int(stream.offsets[i]), int(stream.ordinals[i]))),
                int(stream.kinds[i]) == telemetry,
            )
            for i in range(lo, hi)
        ]

    def state_at(self, ns: int) -> dict[str, Any]:
        found: dict[str, Any] = self.telemetry.at(ns) or self.telemetry.value(0)
        return found

    def geometry_at(self, ns: int) -> dict[str, Any]:
        found: dict[str, Any] = self.geometry.at(ns) or self.geometry.value(0)
        return found

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
        found: dict[str, Any] | None = self.tasks.at(ns)
        return found

    def commands_at(self, ns: int) -> list[dict[str, Any]]:
        """Every command as GET /api/commands would have listed it at `ns`: its latest status,
        oldest first."""
        latest: dict[int, dict[str, Any]] = {}
        for event in self._commands[: int(np.searchsorted(self._command_ns, ns, side="right"))]:
            latest.pop(event["id"], None)
            latest[event["id"]] = topics.command_status(event)
        return sorted(latest.values(), key=lambda r: r["id"])

    # ------------------------------------------------------------------ the file
    def _checked(self, found: Located) -> Any:
        """The message decoded, and shaped as the routes serve it, or an error naming it."""
        value = self._scan.decode(found).value
        topic = found.channel.topic
        fields = _FIELDS[topic]
        wrong = (
            [name for name, kind in fields.items() if not isinstance(value.get(name), kind)]
            if isinstance(value, dict)
            else ["an object"]
        )
        if wrong:
            raise RecordingError(
                f"{self.path}: message {found.number} on {topic}: not a {_schema(topic)} "
                f"(needs {', '.join(wrong)})"
            )
        return value

    def _value(self, offset: int, ordinal: int) -> Any:
        """A message decoded again from its chunk (read with the same bounds as the first pass)."""
        with self._lock:
            messages = self._chunks.get(offset)
            if messages is None:
                messages = self._chunks[offset] = self._scan.reread(offset)
                while len(self._chunks) > CACHED_CHUNKS:
                    self._chunks.popitem(last=False)
            else:
                self._chunks.move_to_end(offset)
        if ordinal >= len(messages):
            raise RecordingError(f"{self.path}: the file changed while it was replayed")
        channel, message = messages[ordinal]
        return self._scan.decode_message(channel, message).value


def _schema(topic: str) -> str:
    return next(t.schema for t in REPLAYED if t.name == topic)

"""The server's command book: the book's rule (robot_sim/command_book.py) shared by the event
loop and the simulation thread under one lock, the API's view of a record, and the ids.

Ids never repeat and only grow, across restarts too, whatever the wall clock does (CommandIds):
each command takes the next integer, from a start past both the wall clock in microseconds and
every id an earlier run put on record. A run records ids in blocks before it gives them out
(one small file write per ID_BLOCK commands, atomically replaced), so a crash loses at most the
rest of a block, never an id's uniqueness; a clock stepped back across a restart (NTP, a VM
restored) cannot bring an old id back. `instance` tells runs apart for a client that saw the
robot restart.
"""

import contextlib
import fcntl
import json
import os
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from ptwl_config import PtwlError

from ptwl.recording.topics import command_event
from robot_sim.behaviors import BehaviorReport
from robot_sim.command_book import CommandBook as Book
from robot_sim.command_book import CommandRecord, Listener
from robot_sim.executor import CommandParams
from robot_sim.finite import finite_or_none, finite_vector_or_none
from robot_sim.limits import SENT_AT_SKEW_S
from robot_sim.policies.run import StepRecord
from server.models import CommandStatus, MachineStepModel, PoseModel

ID_BLOCK = 4096  # ids put on record per write of the state file


class IdRecordError(PtwlError, ValueError):
    """The id record could not be read or moved up (a full disk, a dir made read-only, a file
    damaged under a running robot): no id can be given out that is sure never to repeat."""


def _wall_clock_us() -> int:
    return time.time_ns() // 1000


class CommandIds:
    """Command ids that only grow, across restarts too, even when the wall clock steps back.

    The state file holds `{"next_id": N}`: every id an earlier run gave out is below N. Before a
    run gives out ids it puts a block of them on record (N moves up by ID_BLOCK), so a crash
    leaves N past everything given out. A run starts at max(N, clock in microseconds): past the
    old run's ids whatever the clock says, and near the clock so ids still read as a time. The
    file is read, moved up and replaced under an exclusive lock, so two servers on one data dir
    never take the same block. `state_file=None` keeps nothing (tests, a one-off book): ids then
    start at the clock, and only the clock keeps them apart across runs.
    """

    def __init__(self, state_file: Path | None, clock_us: Callable[[], int] = _wall_clock_us) -> None:
        self._file = state_file
        self._clock_us = clock_us
        self._next = 0
        self._on_record = 0  # ids below this are on record as given out
        self._reserve()

    def take(self) -> int:
        """The next id (callers serialise: the book takes it under its lock)."""
        if self._next >= self._on_record:
            self._reserve()
        taken = self._next
        self._next += 1
        return taken

    def _reserve(self) -> None:
        try:
            self._reserve_block()
        except OSError as err:
            reason = err.strerror or str(err)
            raise IdRecordError(f"command ids cannot be put on record in {self._file}: {reason}") from err
        except ValueError as err:  # the record says something else (it names itself)
            raise IdRecordError(f"command ids cannot be put on record: {err}") from err

    def _reserve_block(self) -> None:
        if self._file is None:
            self._next = max(self._next, self._clock_us())
            self._on_record = self._next + ID_BLOCK
            return
        lock_path = self._file.with_name(self._file.name + ".lock")
        with open(lock_path, "a") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes
            start = max(self._next, _recorded_next_id(self._file), self._clock_us())
            _write_atomically(self._file, json.dumps({"next_id": start + ID_BLOCK}))
        self._next = start
        self._on_record = start + ID_BLOCK


def _recorded_next_id(path: Path) -> int:
    """The state file's `next_id`; 0 when there is no file yet. A file that says something else
    is an error: starting from the clock alone could repeat an id."""
    try:
        text = path.read_text()
    except FileNotFoundError:
        return 0
    try:
        value = json.loads(text)["next_id"]
    except (ValueError, KeyError, TypeError):
        value = None
    if not isinstance(value, int) or isinstance(value, bool) or value < 0:
        raise ValueError(
            f"{path}: not a command id record ({text[:60]!r}); restore it, or delete it only if no "
            "client still holds ids from this robot"
        )
    return value


def _write_atomically(path: Path, text: str) -> None:
    """Replace `path` with `text` so a reader (or a crash) sees the old file or the new, whole."""
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "w") as f:
        f.write(text)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)
    directory = os.open(path.parent, os.O_RDONLY)  # the rename itself survives a power cut too
    try:
        os.fsync(directory)
    finally:
        os.close(directory)


def command_message(record: CommandRecord) -> dict[str, Any]:
    """The record's command event (WS /api/telemetry, MCAP /commands): its status as an event."""
    return command_event(status_model(record).model_dump())


def status_model(record: CommandRecord) -> CommandStatus:
    """The API's view of a record. A fault can leave NaN in the report: such fields become null,
    with the reason in `detail`, so the record stays valid JSON for every reader."""
    r = record.report
    final_wrench, final_port = _final_figures(r) if r else (None, None)
    detail = record.detail
    if r is not None and (final_wrench is None or final_port is None):
        detail = (detail + "; " if detail else "") + "non-finite final wrench or pose reported as null"
    return CommandStatus(
        id=record.id,
        instance=record.instance,
        type=record.params.type,
        status=record.status,
        exit=record.exit,
        params=record.params_json,
        queued_at=record.queued_at,
        started_at=record.started_at,
        ended_at=record.ended_at,
        duration=finite_or_none(r.duration) if r else None,
        peak_force=finite_or_none(r.peak_force) if r else None,
        peak_torque=finite_or_none(r.peak_torque) if r else None,
        final_wrench=final_wrench,
        final_port=final_port,
        detail=detail,
        sender=record.sender,
        goal=PoseModel(**record.goal.as_dict()) if record.goal else None,
        steps=[_step_model(step) for step in record.steps],
        machine=record.machine,
    )


def _final_figures(report: BehaviorReport) -> tuple[list[float] | None, PoseModel | None]:
    """(final wrench, final port) for the API; None where not finite (a fault's NaN)."""
    pose = report.final_port
    finite_pose = finite_vector_or_none([*pose.position, *pose.quaternion]) is not None
    return finite_vector_or_none(report.final_wrench), PoseModel(**pose.as_dict()) if finite_pose else None


def _step_model(step: StepRecord) -> MachineStepModel:
    """A state machine's step for the API: what is not finite (a fault's) becomes null."""
    r = step.report
    final_wrench, final_port = _final_figures(r)
    return MachineStepModel(
        **{
            **step.as_dict(),
            "peak_force": finite_or_none(r.peak_force),
            "peak_torque": finite_or_none(r.peak_torque),
            "final_wrench": final_wrench,
            "final_port": final_port,
        }
    )


class CommandBook:
    """The book (robot_sim/command_book.py) as the server shares it between the event loop
    (submit, read) and the simulation thread (start, finish, stop): every call under one lock,
    briefly; the listener is called under it, so events leave in the order the changes happened
    whichever thread made them. Ids come from CommandIds, the clock is the wall clock."""

    def __init__(
        self,
        queue_max: int,
        history_max: int,
        on_change: Listener | None = None,
        ids: CommandIds | None = None,
        sent_at_skew_s: float = SENT_AT_SKEW_S,
        wall_clock_s: Callable[[], float] = time.time,
    ) -> None:
        self._lock = threading.Lock()
        ids = ids if ids is not None else CommandIds(None)
        self._book = Book(queue_max, history_max, wall_clock_s, on_change, ids.take, sent_at_skew_s)
        self.instance = self._book.instance

    @contextlib.contextmanager
    def held(self) -> Iterator[Book]:
        """The book itself, under the lock (the simulation thread's CommandRunner works on it)."""
        with self._lock:
            yield self._book

    @property
    def running(self) -> CommandRecord | None:
        return self._book.running

    def submit(self, params: CommandParams, sender: str | None = None) -> CommandRecord:
        with self._lock:
            return self._book.submit(params, sender)

    def get(self, command_id: int) -> CommandStatus | None:
        with self._lock:
            record = self._book.record(command_id)
            return status_model(record) if record else None

    def is_done(self, command_id: int) -> bool:
        with self._lock:
            record = self._book.record(command_id)
            return record is not None and record.status == "done"

    def recent(self, limit: int) -> list[CommandStatus]:
        with self._lock:
            return [status_model(r) for r in self._book.recent(limit)]

    def naming_frame(self, name: str) -> list[int]:
        with self._lock:
            return self._book.naming_frame(name)

    def queued_count(self) -> int:
        with self._lock:
            return self._book.queued_count()

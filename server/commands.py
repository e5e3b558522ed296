"""The command book: queued, running and finished commands.

Shared by the event loop (submit, read, stop) and the simulation thread (start, finish), so every
method takes one lock, briefly; nothing here blocks on I/O or physics.

Every status change (queued, running, done, dropped) goes through `_changed`, which hands the
record to the one listener that publishes its event and wakes its waiters; it is called under
the lock, so events leave in the order the changes happened, whichever thread made them.

Ids never repeat and only grow, across restarts too, whatever the wall clock does (CommandIds):
each command takes the next integer, from a start past both the wall clock in microseconds and
every id an earlier run put on record. A run records ids in blocks before it gives them out
(one small file write per ID_BLOCK commands, atomically replaced), so a crash loses at most the
rest of a block, never an id's uniqueness; a clock stepped back across a restart (NTP, a VM
restored) cannot bring an old id back. `instance` tells runs apart for a client that saw the
robot restart.

A command's `sent_at` (the sender's clock) more than the allowed skew in the future is refused
at submission (FutureSentAtError, a 422): judged against it, `max_age` would never run out.
"""

import fcntl
import json
import math
import os
import secrets
import threading
import time
from collections import OrderedDict, deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from robot_sim.behaviors import BehaviorReport
from robot_sim.behaviors.base import ExitCondition, Pose
from robot_sim.executor import CommandParams
from robot_sim.limits import SENT_AT_SKEW_S
from robot_sim.policies.run import StepRecord
from robot_sim.task_frames import frames_named
from server.models import CommandStatus, MachineStepModel, PoseModel


class QueueFullError(Exception):
    def __init__(self, limit: int) -> None:
        super().__init__(
            f"command queue is full ({limit} queued); wait for commands to finish or POST /api/stop"
        )


class FutureSentAtError(ValueError):
    """A command stamped `sent_at` further ahead of the robot's clock than the allowed skew."""

    field = "sent_at"

    def __init__(self, sent_at_s: float, now_s: float, skew_s: float) -> None:
        super().__init__(
            f"must be in [0, now + {skew_s:g}] s (Unix time; now is {now_s:.3f} on the robot's clock, "
            f"which the sender's may lead by at most {skew_s:g} s), got {sent_at_s:.6g}"
        )


ID_BLOCK = 4096  # ids put on record per write of the state file


class IdRecordError(ValueError):
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


def _finite(values: Sequence[float]) -> list[float] | None:
    return [float(v) for v in values] if all(math.isfinite(v) for v in values) else None


def _finite_or_none(value: float) -> float | None:
    return value if math.isfinite(value) else None


@dataclass
class CommandRecord:
    id: int
    instance: str
    params: CommandParams
    params_json: dict[str, Any]  # as validated, defaults filled in (dumped once)
    queued_at: float
    status: str = "queued"
    started_at: float | None = None
    ended_at: float | None = None
    exit: str | None = None
    report: BehaviorReport | None = None
    detail: str = ""
    sender: str | None = None
    goal: Pose | None = None
    steps: list[StepRecord] = field(default_factory=list)  # a state machine's, as they end

    def to_model(self) -> CommandStatus:
        """The API's view. A fault can leave NaN in the report: such fields become null, with
        the reason in `detail`, so the record stays valid JSON for every reader."""
        r = self.report
        final_wrench, final_port = _final_figures(r) if r else (None, None)
        detail = self.detail
        if r is not None and (final_wrench is None or final_port is None):
            detail = (detail + "; " if detail else "") + "non-finite final wrench or pose reported as null"
        return CommandStatus(
            id=self.id,
            instance=self.instance,
            type=self.params.type,
            status=self.status,
            exit=self.exit,
            params=self.params_json,
            queued_at=self.queued_at,
            started_at=self.started_at,
            ended_at=self.ended_at,
            duration=_finite_or_none(r.duration) if r else None,
            peak_force=_finite_or_none(r.peak_force) if r else None,
            peak_torque=_finite_or_none(r.peak_torque) if r else None,
            final_wrench=final_wrench,
            final_port=final_port,
            detail=detail,
            sender=self.sender,
            goal=PoseModel(**self.goal.as_dict()) if self.goal else None,
            steps=[_step_model(step) for step in self.steps],
        )


def _final_figures(report: BehaviorReport) -> tuple[list[float] | None, PoseModel | None]:
    """(final wrench, final port) for the API; None where not finite (a fault's NaN)."""
    pose = report.final_port
    finite_pose = _finite([*pose.position, *pose.quaternion]) is not None
    return _finite(report.final_wrench), PoseModel(**pose.as_dict()) if finite_pose else None


def _step_model(step: StepRecord) -> MachineStepModel:
    """A state machine's step for the API: what is not finite (a fault's) becomes null."""
    r = step.report
    final_wrench, final_port = _final_figures(r)
    return MachineStepModel(
        **{
            **step.as_dict(),
            "peak_force": _finite_or_none(r.peak_force),
            "peak_torque": _finite_or_none(r.peak_torque),
            "final_wrench": final_wrench,
            "final_port": final_port,
        }
    )


Listener = Callable[[CommandRecord], None]


class CommandBook:
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
        self._queue: deque[CommandRecord] = deque()
        self._records: OrderedDict[int, CommandRecord] = OrderedDict()
        self._queue_max = queue_max
        self._history_max = history_max
        self._on_change: Listener = on_change or (lambda record: None)
        self.instance = secrets.token_hex(4)
        self._ids = ids if ids is not None else CommandIds(None)
        self._sent_at_skew_s = sent_at_skew_s
        self._wall_clock_s = wall_clock_s
        self.running: CommandRecord | None = None

    def _changed(self, record: CommandRecord) -> None:
        """(under the lock) The one place a status change is announced."""
        self._on_change(record)

    def submit(self, params: CommandParams, sender: str | None = None) -> CommandRecord:
        now_s = self._wall_clock_s()
        if params.sent_at is not None and params.sent_at > now_s + self._sent_at_skew_s:
            raise FutureSentAtError(params.sent_at, now_s, self._sent_at_skew_s)
        with self._lock:
            if len(self._queue) >= self._queue_max:
                raise QueueFullError(self._queue_max)
            record = CommandRecord(
                self._ids.take(), self.instance, params, params.model_dump(), now_s, sender=sender
            )
            self._queue.append(record)
            self._records[record.id] = record
            self._trim()
            self._changed(record)
            return record

    def start_next(
        self,
        start: Callable[[CommandRecord], Pose | None],
        sim_time_s: float,
        cannot_start: Callable[[CommandParams], str | None] = lambda params: None,
    ) -> CommandRecord | None:
        """Pop the oldest queued command, `start` it and mark it running (simulation thread);
        one whose time has passed (params.py, Expiring) ends `expired` instead, unstarted, and one
        that `cannot_start` gives a reason for (its task frame is gone) ends `aborted`.

        `start` returns the absolute goal the robot resolved (a PTWL's port-at-start (+)
        displacement), so the `running` event carries it: a console can draw the target the robot
        is really heading for, not one it guessed from a delayed port."""
        with self._lock:
            if self.running is not None:
                return None
            while self._queue:
                record = self._queue.popleft()
                reason = record.params.expiry_reason(self._wall_clock_s(), sim_time_s)
                if reason is not None:
                    self._end_unstarted(record, ExitCondition.EXPIRED, reason)
                    continue
                refusal = cannot_start(record.params)
                if refusal is not None:
                    self._end_unstarted(record, ExitCondition.ABORTED, refusal)
                    continue
                return self._start(record, start)
            return None

    def _start(self, record: CommandRecord, start: Callable[[CommandRecord], Pose | None]) -> CommandRecord:
        """(under the lock)"""
        record.goal = start(record)
        record.status = "running"
        record.started_at = self._wall_clock_s()
        self.running = record
        self._changed(record)
        return record

    def finish(self, report: BehaviorReport) -> CommandRecord | None:
        """The running command ended with `report` (simulation thread)."""
        with self._lock:
            record = self.running
            if record is None:
                return None
            record.status = "done"
            record.exit = report.exit.value
            record.report = report
            record.detail = report.detail
            record.ended_at = self._wall_clock_s()
            self.running = None
            self._changed(record)
            return record

    def step_done(self, step: StepRecord) -> None:
        """A step of the running state machine ended (simulation thread): announced while the
        machine goes on, so a watcher sees each step and why the next was chosen."""
        with self._lock:
            if self.running is not None:
                self.running.steps.append(step)
                self._changed(self.running)

    def drop_queued(self, detail: str) -> list[CommandRecord]:
        """End every queued command `aborted` without running it."""
        with self._lock:
            dropped = list(self._queue)
            self._queue.clear()
            for record in dropped:
                self._end_unstarted(record, ExitCondition.ABORTED, detail)
            return dropped

    def _end_unstarted(self, record: CommandRecord, exit: ExitCondition, detail: str) -> None:
        """(under the lock) A queued command ends without having run."""
        record.status = "done"
        record.exit = exit.value
        record.detail = detail
        record.ended_at = self._wall_clock_s()
        self._changed(record)

    def get(self, command_id: int) -> CommandStatus | None:
        with self._lock:
            record = self._records.get(command_id)
            return record.to_model() if record else None

    def is_done(self, command_id: int) -> bool:
        with self._lock:
            record = self._records.get(command_id)
            return record is not None and record.status == "done"

    def recent(self, limit: int) -> list[CommandStatus]:
        with self._lock:
            records = list(self._records.values())[-limit:]
            return [r.to_model() for r in records]

    def naming_frame(self, name: str) -> list[int]:
        """Ids of the queued and running commands that name the task frame `name`."""
        with self._lock:
            waiting = [*self._queue, *([self.running] if self.running else [])]
            return sorted(r.id for r in waiting if name in frames_named(r.params).values())

    def queued_count(self) -> int:
        with self._lock:
            return len(self._queue)

    def _trim(self) -> None:
        while len(self._records) > self._history_max:
            oldest_id = next(iter(self._records))
            if self._records[oldest_id].status != "done":
                break
            del self._records[oldest_id]

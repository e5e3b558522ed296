"""The command book: queued, running and finished commands.

Shared by the event loop (submit, read, stop) and the simulation thread (start, finish), so every
method takes one lock, briefly; nothing here blocks on I/O or physics.
"""

import threading
import time
from collections import OrderedDict, deque
from dataclasses import dataclass
from typing import Any

from robot_sim.behaviors import BehaviorParams, BehaviorReport
from server.models import CommandStatus, PoseModel


class QueueFullError(Exception):
    def __init__(self, limit: int) -> None:
        super().__init__(
            f"command queue is full ({limit} queued); wait for commands to finish or POST /api/stop"
        )


@dataclass
class CommandRecord:
    id: int
    params: BehaviorParams
    params_json: dict[str, Any]  # as validated, defaults filled in (dumped once)
    queued_at: float
    status: str = "queued"
    started_at: float | None = None
    ended_at: float | None = None
    exit: str | None = None
    report: BehaviorReport | None = None
    detail: str = ""

    def to_model(self) -> CommandStatus:
        r = self.report
        return CommandStatus(
            id=self.id,
            type=self.params.type,
            status=self.status,
            exit=self.exit,
            params=self.params_json,
            queued_at=self.queued_at,
            started_at=self.started_at,
            ended_at=self.ended_at,
            duration=r.duration if r else None,
            peak_force=r.peak_force if r else None,
            peak_torque=r.peak_torque if r else None,
            final_wrench=list(r.final_wrench) if r else None,
            final_port=PoseModel(**r.final_port.as_dict()) if r else None,
            detail=self.detail,
        )


class CommandBook:
    def __init__(self, queue_max: int, history_max: int) -> None:
        self._lock = threading.Lock()
        self._queue: deque[CommandRecord] = deque()
        self._records: OrderedDict[int, CommandRecord] = OrderedDict()
        self._queue_max = queue_max
        self._history_max = history_max
        self._next_id = 1
        self.running: CommandRecord | None = None

    def submit(self, params: BehaviorParams) -> CommandRecord:
        with self._lock:
            if len(self._queue) >= self._queue_max:
                raise QueueFullError(self._queue_max)
            record = CommandRecord(self._next_id, params, params.model_dump(), time.time())
            self._next_id += 1
            self._queue.append(record)
            self._records[record.id] = record
            self._trim()
            return record

    def start_next(self) -> CommandRecord | None:
        """Pop the oldest queued command and mark it running (simulation thread)."""
        with self._lock:
            if self.running is not None or not self._queue:
                return None
            record = self._queue.popleft()
            record.status = "running"
            record.started_at = time.time()
            self.running = record
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
            record.ended_at = time.time()
            self.running = None
            return record

    def drop_queued(self, detail: str) -> list[CommandRecord]:
        """End every queued command `aborted` without running it."""
        with self._lock:
            dropped = list(self._queue)
            self._queue.clear()
            now = time.time()
            for record in dropped:
                record.status = "done"
                record.exit = "aborted"
                record.detail = detail
                record.ended_at = now
            return dropped

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

    def queued_count(self) -> int:
        with self._lock:
            return len(self._queue)

    def _trim(self) -> None:
        while len(self._records) > self._history_max:
            oldest_id = next(iter(self._records))
            if self._records[oldest_id].status != "done":
                break
            del self._records[oldest_id]

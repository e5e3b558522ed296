"""The command book: the one rule of a command's life, from queued to its exit.

Queued commands run in order, one at a time. A command is judged as it is about to start: one
whose time has passed (params.py, Expiring) ends `expired` and one that `cannot_start` names a
reason for (its task frame is gone) ends `aborted`, both unstarted. At most `queue_max` wait; a
`sent_at` more than the allowed skew ahead of the book's clock is refused (judged against it,
`max_age` would never run out). STOP drops the queue (`aborted`, "dropped by stop"). Every status
change (queued, running, a state machine's step, done) goes through `on_change`, in the order
the changes happened; the book keeps the last `history_max` ended commands.

Clock-free and thread-free, so the robot server (real time, its own lock: server/commands.py),
the sweeps' virtual robot (virtual time: ptwl/experiments/sweep/robot.py) and the ground twin's trial
harness run this same rule: the clock (Unix seconds, real or virtual) and the ids are given.
"""

import itertools
import secrets
from collections import OrderedDict, deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from robot_sim.behaviors import BehaviorReport
from robot_sim.behaviors.base import ExitCondition, Pose
from robot_sim.errors import RobotSimError
from robot_sim.executor import CommandParams
from robot_sim.limits import SENT_AT_SKEW_S
from robot_sim.policies.run import StepRecord
from robot_sim.task_frames import frames_named

STOP_DETAIL = "dropped by stop"


class QueueFullError(RobotSimError):
    def __init__(self, limit: int) -> None:
        super().__init__(
            f"command queue is full ({limit} queued); wait for commands to finish or POST /api/stop"
        )


class FutureSentAtError(RobotSimError, ValueError):
    """A command stamped `sent_at` further ahead of the robot's clock than the allowed skew."""

    field = "sent_at"

    def __init__(self, sent_at_s: float, now_s: float, skew_s: float) -> None:
        super().__init__(
            f"must be in [0, now + {skew_s:g}] s (Unix time; now is {now_s:.3f} on the robot's clock, "
            f"which the sender's may lead by at most {skew_s:g} s), got {sent_at_s:.6g}"
        )


@dataclass
class CommandRecord:
    id: int
    instance: str
    params: CommandParams
    params_json: dict[str, Any]  # as validated, defaults filled in (dumped once)
    queued_at: float  # [s] Unix time, by the book's clock
    status: str = "queued"
    started_at: float | None = None
    ended_at: float | None = None
    exit: str | None = None
    report: BehaviorReport | None = None
    detail: str = ""
    sender: str | None = None
    goal: Pose | None = None
    steps: list[StepRecord] = field(default_factory=list)  # a state machine's, as they end
    machine: dict[str, Any] | None = None  # a state machine's state, pending decision, decisions


Listener = Callable[[CommandRecord], None]


class CommandBook:
    def __init__(
        self,
        queue_max: int,
        history_max: int,
        clock_s: Callable[[], float],
        on_change: Listener | None = None,
        take_id: Callable[[], int] | None = None,
        sent_at_skew_s: float = SENT_AT_SKEW_S,
        instance: str | None = None,
    ) -> None:
        self._queue: deque[CommandRecord] = deque()
        self._records: OrderedDict[int, CommandRecord] = OrderedDict()
        self._queue_max = queue_max
        self._history_max = history_max
        self._clock_s = clock_s  # [s] Unix time: what `sent_at` and `max_age` are judged by
        self._on_change: Listener = on_change or (lambda record: None)
        self._take_id = take_id or itertools.count(1).__next__
        self._sent_at_skew_s = sent_at_skew_s
        self.instance = instance or secrets.token_hex(4)
        self.running: CommandRecord | None = None

    def submit(self, params: CommandParams, sender: str | None = None) -> CommandRecord:
        now_s = self._clock_s()
        if params.sent_at is not None and params.sent_at > now_s + self._sent_at_skew_s:
            raise FutureSentAtError(params.sent_at, now_s, self._sent_at_skew_s)
        if len(self._queue) >= self._queue_max:
            raise QueueFullError(self._queue_max)
        record = CommandRecord(
            self._take_id(), self.instance, params, params.model_dump(), now_s, sender=sender
        )
        self._queue.append(record)
        self._records[record.id] = record
        self._trim()
        self._on_change(record)
        return record

    def start_next(
        self,
        start: Callable[[CommandRecord], Pose | None],
        sim_time_s: float,
        cannot_start: Callable[[CommandParams], str | None] = lambda params: None,
    ) -> CommandRecord | None:
        """Pop the oldest queued command, `start` it and mark it running, unless one runs; the
        expired and the unstartable end on the way.

        `start` returns the absolute goal the robot resolved (a PTWL's port-at-start (+)
        displacement), so the `running` event carries it: a console can draw the target the robot
        is really heading for, not one it guessed from a delayed port."""
        if self.running is not None:
            return None
        while self._queue:
            record = self._queue.popleft()
            reason = record.params.expiry_reason(self._clock_s(), sim_time_s)
            if reason is not None:
                self._end_unstarted(record, ExitCondition.EXPIRED, reason)
                continue
            refusal = cannot_start(record.params)
            if refusal is not None:
                self._end_unstarted(record, ExitCondition.ABORTED, refusal)
                continue
            record.goal = start(record)
            record.status = "running"
            record.started_at = self._clock_s()
            self.running = record
            self._on_change(record)
            return record
        return None

    def finish(self, report: BehaviorReport) -> CommandRecord | None:
        """The running command ended with `report`."""
        record = self.running
        if record is None:
            return None
        record.status = "done"
        record.exit = report.exit.value
        record.report = report
        record.detail = report.detail
        record.ended_at = self._clock_s()
        self.running = None
        self._on_change(record)
        return record

    def step_done(self, step: StepRecord) -> None:
        """A step of the running state machine ended: announced while the machine goes on, so a
        watcher sees each step and why the next was chosen."""
        if self.running is not None:
            self.running.steps.append(step)
            self._on_change(self.running)

    def changed(self, record: CommandRecord) -> None:
        """`record` changed in place (a machine's decision asked or taken): announce it."""
        self._on_change(record)

    def drop_queued(self, detail: str = STOP_DETAIL) -> list[CommandRecord]:
        """End every queued command `aborted` without running it."""
        dropped = list(self._queue)
        self._queue.clear()
        for record in dropped:
            self._end_unstarted(record, ExitCondition.ABORTED, detail)
        return dropped

    def _end_unstarted(self, record: CommandRecord, exit: ExitCondition, detail: str) -> None:
        record.status = "done"
        record.exit = exit.value
        record.detail = detail
        record.ended_at = self._clock_s()
        self._on_change(record)

    def record(self, command_id: int) -> CommandRecord | None:
        return self._records.get(command_id)

    def recent(self, limit: int) -> list[CommandRecord]:
        """The last `limit` commands, oldest first."""
        return list(self._records.values())[-limit:]

    def naming_frame(self, name: str) -> list[int]:
        """Ids of the queued and running commands that name the task frame `name`."""
        waiting = [*self._queue, *([self.running] if self.running else [])]
        return sorted(r.id for r in waiting if name in frames_named(r.params).values())

    def queued_count(self) -> int:
        return len(self._queue)

    def _trim(self) -> None:
        while len(self._records) > self._history_max:
            oldest_id = next(iter(self._records))
            if self._records[oldest_id].status != "done":
                break
            del self._records[oldest_id]

"""The robot side of a virtual-time trial: the task's scene, its commands run by the server's own
rule (robot_sim/command_book.py: queue, ids, the 64-command cap, expiry judged at the start, the
task-frame gate, lifecycle; robot_sim/command_runner.py: what a command does on the robot) on the
trial's clock, and the figures the paper's tables use, measured where they happen (on the
robot), not where they are reported.

It speaks the messages of the real API, as Python objects: a POST of a command (answered with
its acceptance), a GET of a command's status, and a command event when one ends.
"""

import math
from collections.abc import Callable
from dataclasses import dataclass, field

from robot_sim.behaviors import BehaviorReport
from robot_sim.command_book import CommandBook, CommandRecord
from robot_sim.command_runner import CommandRunner, Stopped
from robot_sim.executor import CommandParams, DecisionError
from robot_sim.limits import COMMAND_HISTORY_MAX, COMMAND_QUEUE_MAX
from robot_sim.machines.command import DecisionRequest
from robot_sim.policies.run import StepRecord
from robot_sim.sim import UNBOUNDED_TICKS, Simulation

# The trial's clock as Unix time (what `sent_at` and `max_age` are judged by): its t = 0. Zero, so
# that a record's times (queued_at, started_at, ended_at) are the trial's sim seconds, the clock
# of its recording's log times (a replay lays commands on the timeline by them).
VIRTUAL_EPOCH_S = 0.0


@dataclass(frozen=True)
class Post:
    """POST /api/commands: the command, tagged by its sender (the operator's own name for it)."""

    tag: str
    params: CommandParams


@dataclass(frozen=True)
class Query:
    """GET /api/commands/{id}, by the sender's tag."""

    tag: str


@dataclass(frozen=True)
class Decide:
    """POST /api/commands/{id}/decision: the operator's answer to a waiting machine's decision."""

    tag: str
    request: DecisionRequest


@dataclass(frozen=True)
class Accepted:
    tag: str


@dataclass(frozen=True)
class Refused:
    """A decision the robot would not take (the API's 409: another one is pending, or none; or
    422: a state or outcome the machine has not)."""

    tag: str
    why: str


@dataclass(frozen=True)
class Asked:
    """The command event of a machine that now waits for decision `number` (a WebSocket
    message: it can be lost; a status answer says it too)."""

    tag: str
    number: int


@dataclass(frozen=True)
class Outcome:
    """How a command ended: its exit and detail, and the report of its run (None: it never ran,
    e.g. `expired` in the queue, or `aborted` by STOP or for a frame it named that was gone)."""

    exit: str
    detail: str
    report: BehaviorReport | None

    @staticmethod
    def of(record: CommandRecord) -> "Outcome":
        assert record.exit is not None
        return Outcome(record.exit, record.detail or "", record.report)


@dataclass(frozen=True)
class Status:
    """The answer to a Query: unknown (the POST never arrived), still going, or how it ended."""

    tag: str
    known: bool
    outcome: Outcome | None  # set when done
    pending: int | None = None  # a running machine's decision waiting for the operator


@dataclass(frozen=True)
class Done:
    """The command event of a command that ended (a WebSocket message: it can be lost)."""

    tag: str
    outcome: Outcome


Request = Post | Query | Decide
Reply = Accepted | Status | Refused
Event = Done | Asked


@dataclass
class Figures:
    """Accumulated on the robot, tick by tick, from the first behavior's start to the last's end."""

    steps: list[StepRecord] = field(default_factory=list)  # every behavior that ran, in order
    first_start_s: float | None = None
    force_sum: float = 0.0  # [N x ticks] while a behavior ran or the robot held between them
    torque_sum: float = 0.0  # [N m x ticks]
    ticks: int = 0
    at_last_end: tuple[float, float, int] = (0.0, 0.0, 0)  # the sums when the last behavior ended

    def mean_force_n(self) -> float:
        force, _, ticks = self.at_last_end
        return force / ticks if ticks else 0.0

    def mean_torque_nm(self) -> float:
        _, torque, ticks = self.at_last_end
        return torque / ticks if ticks else 0.0


def _pending(record: CommandRecord | None) -> int | None:
    """The number of the decision a running machine's record says waits, if one does."""
    machine = record.machine if record is not None else None
    pending = machine.get("pending") if machine is not None else None
    return int(pending["decision"]) if pending else None


class VirtualRobot:
    def __init__(self, task: str, seed: int) -> None:
        self.sim = Simulation(task, seed)
        self.book = CommandBook(
            COMMAND_QUEUE_MAX, COMMAND_HISTORY_MAX, self.unix_time_s, self._changed, instance="virtual"
        )
        self.commands = CommandRunner(self.sim, self.book, self._step_ended)
        self.figures = Figures()
        # A recording's hooks (ptwl/experiments/sweep/recorder.py), called as the server's are:
        # every record's change as it happens, and every behavior's end by command id, before
        # the end of the command it belongs to.
        self.on_record: Callable[[CommandRecord], None] | None = None
        self.on_step: Callable[[int, StepRecord], None] | None = None
        # Every command's record by its tag, in the order they arrived (the tag is its sender).
        self.submitted: dict[str, CommandRecord] = {}
        # Events not announced yet, in the order they happened: a command's end, a decision asked.
        self._outbox: list[Event] = []
        self._asked: set[tuple[int, int]] = set()  # (command id, decision number) announced
        self.decisions_waited = 0  # decisions the machines waited for the operator on
        self.decision_wait_s = 0.0  # [s] sim time they waited, in total

    def _changed(self, record: CommandRecord) -> None:
        if self.on_record is not None:
            self.on_record(record)
        assert record.sender is not None
        if record.status == "done":  # run, or not: expired, dropped by STOP, refused at its start
            if record.machine is not None:
                self.decisions_waited += int(record.machine["decisions_waited"])
                self.decision_wait_s += float(record.machine["waited_s"])
            self._outbox.append(Done(record.sender, Outcome.of(record)))
        elif (number := _pending(record)) is not None and (record.id, number) not in self._asked:
            self._asked.add((record.id, number))  # announced once, whatever else changes
            self._outbox.append(Asked(record.sender, number))

    def _step_ended(self, command_id: int, step: StepRecord) -> None:
        if self.on_step is not None:
            self.on_step(command_id, step)

    @property
    def running_tag(self) -> str | None:
        running = self.book.running
        return running.sender if running is not None else None

    def unix_time_s(self) -> float:
        return VIRTUAL_EPOCH_S + self.sim.time

    def stop(self) -> Stopped:
        """POST /api/stop (the sweeps' operators never send it; scripts and tests do)."""
        return self.commands.stop_all()

    def add_frame(self, name: str) -> None:
        """POST /api/frames at the tool (scripts and tests do; the sweeps' operators do not)."""
        self.sim.add_operator_frame(name)

    def remove_frame(self, name: str) -> None:
        """DELETE /api/frames/{name}: refused while a queued or running command names it."""
        self.sim.frames.remove(name, self.book.naming_frame(name))

    def handle(self, request: Request) -> Reply:
        """A request that arrived; its answer (the server answers between 2 ms batches)."""
        if isinstance(request, Post):
            if request.tag not in self.submitted:  # a resent POST that did arrive is not run twice
                self.submitted[request.tag] = self.book.submit(request.params, sender=request.tag)
            return Accepted(request.tag)
        record = self.submitted.get(request.tag)  # its exit is set as it ends
        if isinstance(request, Decide):
            if record is None:
                return Refused(request.tag, "no such command")
            try:
                self.commands.decide(record.id, request.request)
            except DecisionError as err:
                return Refused(request.tag, str(err))
            return Accepted(request.tag)
        if record is None:
            return Status(request.tag, False, None)
        if record.status == "done":
            return Status(request.tag, True, Outcome.of(record))
        return Status(request.tag, True, None, _pending(record))

    def tick(self, until_s: float = -math.inf) -> Event | None:
        """One control period, or more up to `until_s` [s] sim time while nothing else can happen:
        start the next queued command if idle, step; a command that ended (run or not: the server
        announces each as it ends), one a tick, in the order they ended."""
        sim, figures = self.sim, self.figures
        if self.commands.start_next() is not None and figures.first_start_s is None:
            figures.first_start_s = sim.time
        # After start_next the queue is empty or a behavior runs, and only a behavior's end (which
        # stops the run) can start anything before the link acts again at `until_s`; ended
        # commands still to announce go one a tick.
        counting = figures.first_start_s is not None
        ctl = sim.controller
        if counting:  # the compiled loop adds each tick's |f| and |tau| to the sums (tick.py)
            ctl.set_norm_sums(figures.force_sum, figures.torque_sum)
        faults = sim.fault_count
        report, ran = sim.advance(1 if self._outbox else UNBOUNDED_TICKS, until_s)
        if sim.fault_count != faults:
            self.commands.scene_reloaded()  # a machine waiting for a decision ends `fault`
        if counting:  # from the controller they were added on: a fault has since made a new one
            figures.force_sum, figures.torque_sum = ctl.norm_sums()
            figures.ticks += ran
        if report is not None:
            figures.at_last_end = (figures.force_sum, figures.torque_sum, figures.ticks)
            figures.steps.append(self.commands.behavior_ended(report)[1].step)
        # The oldest event; any others follow on the next ticks.
        return self._outbox.pop(0) if self._outbox else None

    def tick_until(self, until_s: float) -> Event | None:
        """One tick, then more while nothing else can happen before `until_s` (the next instant
        the link or the operator acts): a quiet stretch costs the physics and no bookkeeping.
        Stops at the first command that ends."""
        tick, sim = self.tick, self.sim
        done = tick(until_s)
        while done is None and sim.time < until_s:
            done = tick(until_s)
        return done

    @property
    def last_end_s(self) -> float | None:
        steps = self.figures.steps
        return steps[-1].report.ended_at if steps else None

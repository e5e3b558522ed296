"""The two operators of a sweep, as a person at the ground station would act.

`ground`: runs the task's policy on the ground. It sends one behavior, waits for its report to
come down the link, thinks (a seeded draw), and sends the next: Ferrell's move-and-wait.
`onboard`: sends one `state_machine` command and waits for its delayed completion.

Neither holds a clock or a socket: every call gets `now` [s], and what an operator wants sent
up the link comes back as a list of requests; `wake_at` says when it next wants to act if
nothing arrives. A lost POST or event is handled as an operator would: once the report is
overdue, ask for the command's status (GET, by its tag); if the robot never got it, send it
again. Nothing waits forever: every wait has a deadline that leads to a question.

With a max age (`ptwl sweep --max-age`) every command carries `sent_at` (the operator's clock as
Unix time) and `max_age`, as the console's do; one the robot expired (or ended without running
for another reason) is sent again as a new command, up to UNSTARTED_MAX times in a row, after
which the operator gives up: the link is slower than the age it allows.
"""

from abc import ABC, abstractmethod
from dataclasses import dataclass
from pathlib import Path

from ptwl.experiments.sweep.robot import (
    Accepted,
    Asked,
    Decide,
    Done,
    Event,
    Outcome,
    Post,
    Query,
    Refused,
    Reply,
    Request,
    Status,
)
from ptwl.experiments.sweep.spec import TrialSpec
from robot_sim.behaviors import BehaviorReport, Pose
from robot_sim.executor import CommandParams
from robot_sim.machines.command import DecisionRequest, StateMachineParams
from robot_sim.machines.library import read_machine
from robot_sim.params import GripperParams, RweParams
from robot_sim.policies import Machine, policy_for

PATIENCE_S = 2.0  # [s] past a behavior's latest possible end (and the round trip) before asking
POLL_S = 10.0  # [s] between questions about a state machine, whose length nobody knows ahead
THINK_SPREAD = (0.5, 1.5)  # a think time is uniform in this range times the mean
UNSTARTED_MAX = 3  # commands in a row that end without running before the operator gives up


def latest_end_s(params: CommandParams) -> float | None:
    """[s] from start, the longest a behavior can run (its watchdog); None for a state machine."""
    if isinstance(params, StateMachineParams):
        return None
    if isinstance(params, RweParams | GripperParams):
        return params.duration
    assert params.watchdog is not None  # PTWL and Dither fill it in
    return params.watchdog


@dataclass
class Pending:
    tag: str
    params: CommandParams
    deadline_s: float  # when to ask about it if nothing has come down


class Operator(ABC):
    def __init__(self, spec: TrialSpec, epoch_s: float) -> None:
        self.spec = spec
        self._epoch_s = epoch_s  # [s] Unix time at the operator's t = 0 (`sent_at` stamps)
        self.commands_sent = 0  # POSTs, a resend included
        self.wait_cycles = 0  # commands waited for (move-and-wait cycles)
        self.requeries = 0  # GETs after a report was overdue
        self.unstarted = 0  # commands that ended without running (expired), sent again
        self._unstarted_in_row = 0
        self.think_s = 0.0  # [s] thought in total
        self.pending: Pending | None = None
        self.end: str | None = None  # how the task ended, as the operator learned it
        self.why = ""
        self.finished_at_s: float | None = None  # [s] when the operator learned it
        self._next: tuple[float, CommandParams] | None = None  # a command to send once thought
        self._sent = 0

    # ------------------------------------------------------------------ the interface
    @abstractmethod
    def begin(self, now: float, port: Pose) -> list[Request]:
        """The trial starts; `port` is the latest telemetry (the robot at rest, before t = 0)."""

    @abstractmethod
    def _ended(self, now: float, report: BehaviorReport) -> None:
        """The pending command's report came down."""

    @property
    def wake_at(self) -> float | None:
        """A command waiting out a think time, else the pending one's deadline (never both: a
        think starts when a report ends the pending command)."""
        if self._next is not None:
            return self._next[0]
        return self.pending.deadline_s if self.pending is not None else None

    def on_message(self, now: float, message: Reply | Event) -> list[Request]:
        pending = self.pending
        if pending is None or message.tag != pending.tag or isinstance(message, Accepted | Refused):
            return []  # stale (an answer to an earlier question), or only an acknowledgement
        if isinstance(message, Done):
            return self._outcome(now, message.outcome)
        if isinstance(message, Asked):
            return self._asked(now, message.number)
        assert isinstance(message, Status)
        if message.outcome is not None:
            return self._outcome(now, message.outcome)
        if message.pending is not None:
            pending.deadline_s = now + self._patience(pending.params)
            return self._asked(now, message.pending)
        if message.known:  # still queued or running: ask again later
            pending.deadline_s = now + self._patience(pending.params)
            return []
        return [self._post(now, pending.params, resend=True)]  # the POST never arrived

    def on_wake(self, now: float) -> list[Request]:
        if self._next is not None and self._next[0] <= now:
            params = self._next[1]
            self._next = None
            return [self._post(now, params)]
        pending = self.pending
        if pending is not None and pending.deadline_s <= now:
            self.requeries += 1
            pending.deadline_s = now + self.spec.rtt_s + PATIENCE_S
            return [Query(pending.tag)]
        return []

    def _asked(self, now: float, number: int) -> list[Request]:
        """The running machine waits for decision `number` (only a supervised machine's does)."""
        return []

    @property
    def finished(self) -> bool:
        return self.finished_at_s is not None

    # ---------------------------------------------------------------------- helpers
    def _patience(self, params: CommandParams) -> float:
        latest = latest_end_s(params)
        return self.spec.rtt_s + (POLL_S if latest is None else latest + PATIENCE_S)

    def _outcome(self, now: float, outcome: Outcome) -> list[Request]:
        pending = self.pending
        assert pending is not None
        if outcome.report is not None:
            self._unstarted_in_row = 0
            self._report(now, outcome.report)
            return []
        # It never ran (expired on the way or in the queue): the operator sends it again, freshly
        # stamped, unless the link has made every recent send too old to run.
        self.unstarted += 1
        self._unstarted_in_row += 1
        if self._unstarted_in_row >= UNSTARTED_MAX:
            self.pending = None
            self._finish(
                now, outcome.exit, f"{UNSTARTED_MAX} commands in a row ended unrun: {outcome.detail}"
            )
            return []
        return [self._post(now, pending.params)]

    def _post(self, now: float, params: CommandParams, resend: bool = False) -> Post:
        max_age_s = self.spec.max_age_s
        if max_age_s is not None:
            params = params.model_copy(update={"sent_at": self._epoch_s + now, "max_age": max_age_s})
        if resend:
            assert self.pending is not None
            tag = self.pending.tag  # the robot runs a tag once, however often it arrives
        else:
            self._sent += 1
            self.wait_cycles += 1
            tag = f"{self.spec.operator}-{self._sent}"
        self.commands_sent += 1
        self.pending = Pending(tag, params, now + self._patience(params))
        return Post(tag, params)

    def _report(self, now: float, report: BehaviorReport) -> None:
        self.pending = None
        self._ended(now, report)

    def _finish(self, now: float, end: str, why: str) -> None:
        self.end, self.why, self.finished_at_s = end, why, now


class GroundOperator(Operator):
    """The task's policy on the ground: one behavior per round trip, with think time."""

    def __init__(self, spec: TrialSpec, epoch_s: float) -> None:
        super().__init__(spec, epoch_s)
        self.machine = Machine(policy_for(spec.task))
        self._think = spec.rng("think")

    def begin(self, now: float, port: Pose) -> list[Request]:
        return [self._post(now, self.machine.start(port).params)]

    def _ended(self, now: float, report: BehaviorReport) -> None:
        step = self.machine.advance(report)
        if step is None:
            assert self.machine.exit is not None and self.machine.finish is not None
            self._finish(now, self.machine.exit.value, self.machine.finish.why)
            return
        think = self._think.uniform(*THINK_SPREAD) * self.spec.think_s
        self.think_s += think
        self._next = (now + think, step.params)


class OnboardOperator(Operator):
    """One state-machine command; the robot runs each next step at once, or (an autonomy level
    below some transitions') waits for the operator, who confirms each decision asked after a
    think time, across the link."""

    def __init__(self, spec: TrialSpec, epoch_s: float) -> None:
        super().__init__(spec, epoch_s)
        self._think = spec.rng("think")
        self._decision: tuple[float, int] | None = None  # (when to answer, which decision)
        self._answered: set[int] = set()
        self.decisions_answered = 0
        self.decision_thinks_s: list[float] = []  # [s] each decision's think time, in order

    def begin(self, now: float, port: Pose) -> list[Request]:
        machine = read_machine(Path(self.spec.machine)) if self.spec.machine else None
        params = (
            StateMachineParams(machine=machine)
            if machine is not None
            else StateMachineParams(task=self.spec.task)
        )
        if self.spec.autonomy is not None:
            params = params.model_copy(update={"autonomy": self.spec.autonomy})
        return [self._post(now, params)]

    @property
    def wake_at(self) -> float | None:
        base = super().wake_at
        if self._decision is None:
            return base
        return self._decision[0] if base is None else min(base, self._decision[0])

    def on_wake(self, now: float) -> list[Request]:
        decision = self._decision
        if decision is not None and decision[0] <= now:
            self._decision = None
            if self.pending is not None:  # else the machine ended meanwhile: nothing to answer
                return [self._decide(decision[1])]
        return super().on_wake(now)

    def _asked(self, now: float, number: int) -> list[Request]:
        if number in self._answered:  # still pending after the answer: the answer was lost
            return [self._decide(number)]
        if self._decision is None or self._decision[1] != number:
            think = self._think.uniform(*THINK_SPREAD) * self.spec.think_s
            self.think_s += think
            self.decision_thinks_s.append(think)
            self._decision = (now + think, number)
        return []

    def _decide(self, number: int) -> Decide:
        assert self.pending is not None
        if number not in self._answered:
            self._answered.add(number)
            self.decisions_answered += 1
        self.commands_sent += 1
        return Decide(self.pending.tag, DecisionRequest(decision=number, choice="confirm"))

    def _ended(self, now: float, report: BehaviorReport) -> None:
        self._finish(now, report.exit.value, report.detail)


def operator_for(spec: TrialSpec, epoch_s: float) -> Operator:
    """The spec's operator, its clock's t = 0 at Unix time `epoch_s`."""
    return GroundOperator(spec, epoch_s) if spec.operator == "ground" else OnboardOperator(spec, epoch_s)

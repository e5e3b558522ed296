"""The one command lifecycle (robot_sim/command_book.py), on a fake clock: what the server, the
sweeps' virtual robot and the twin's harness all run."""

import pytest

from robot_sim.behaviors import BehaviorReport, Pose
from robot_sim.behaviors.base import ExitCondition
from robot_sim.command_book import CommandBook, CommandRecord, FutureSentAtError, QueueFullError
from robot_sim.params import PtwlParams, RweParams
from robot_sim.policies.run import StepRecord
from tests.fake_clock import FakeClock

EPOCH_S = 1_000.0


class Book:
    """A book on a fake clock that remembers every event as (id, status, exit)."""

    def __init__(self, queue_max: int = 8, history_max: int = 16, skew_s: float = 5.0) -> None:
        self.clock = FakeClock(EPOCH_S)
        self.events: list[tuple[int, str, str | None]] = []
        self.book = CommandBook(
            queue_max, history_max, self.clock, self._changed, sent_at_skew_s=skew_s, instance="test"
        )
        self.started: list[int] = []

    def _changed(self, record: CommandRecord) -> None:
        self.events.append((record.id, record.status, record.exit))

    def start_next(self, sim_time_s: float = 0.0, cannot_start=lambda params: None) -> CommandRecord | None:  # type: ignore[no-untyped-def]
        return self.book.start_next(lambda r: self.started.append(r.id), sim_time_s, cannot_start)  # type: ignore[func-returns-value]


def report_for(book: Book, exit_name: str = "goal_reached") -> BehaviorReport:
    port = Pose((0.0, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0))
    return BehaviorReport("ptwl", ExitCondition(exit_name), 0.0, 1.0, 3.0, 0.1, (0.0,) * 6, port, "why")


def test_the_lifecycle_is_announced_in_order_with_the_books_clock() -> None:
    b = Book()
    first = b.book.submit(PtwlParams(), sender="ana")
    second = b.book.submit(RweParams())
    assert (first.id, second.id) == (1, 2) and first.queued_at == EPOCH_S and first.sender == "ana"
    b.clock.now += 0.25
    assert b.start_next() is first and b.start_next() is None  # one at a time
    assert first.started_at == EPOCH_S + 0.25 and b.started == [1]
    b.clock.now += 1.0
    assert b.book.finish(report_for(b)) is first
    assert first.ended_at == EPOCH_S + 1.25 and first.exit == "goal_reached" and first.detail == "why"
    assert b.start_next() is second
    assert b.events == [
        (1, "queued", None),
        (2, "queued", None),
        (1, "running", None),
        (1, "done", "goal_reached"),
        (2, "running", None),
    ]


def test_max_age_is_judged_at_the_start_not_when_queued() -> None:
    """A command fresh when it reached the queue expires if it waited there past its max_age."""
    b = Book()
    b.book.submit(RweParams(duration=2.0))
    waiting = b.book.submit(PtwlParams(sent_at=EPOCH_S, max_age=1.0))
    patient = b.book.submit(PtwlParams(sent_at=EPOCH_S, max_age=3.0))
    b.start_next()
    b.clock.now += 2.0  # the first ran 2 s; the second was 0 s old when queued
    b.book.finish(report_for(b))
    assert b.start_next() is patient
    assert waiting.exit == "expired" and waiting.started_at is None and waiting.ended_at == EPOCH_S + 2.0
    assert waiting.detail == "2.00 s old at its start, over its max_age 1 s"
    assert b.started == [1, patient.id]  # the expired one never reached the robot


def test_valid_until_sim_time_is_judged_by_the_sim_time_at_the_start() -> None:
    b = Book()
    late = b.book.submit(PtwlParams(valid_until_sim_time=1.0))
    b.book.submit(PtwlParams(valid_until_sim_time=1.0))
    assert b.start_next(sim_time_s=1.0) is not None and late.status == "running"  # equal: valid
    b.book.finish(report_for(b))
    assert b.start_next(sim_time_s=1.001) is None
    assert b.events[-1][1:] == ("done", "expired")


def test_a_command_that_cannot_start_ends_aborted_and_the_next_starts() -> None:
    b = Book()
    gone = b.book.submit(PtwlParams(frame="bolt"))
    fine = b.book.submit(PtwlParams())
    reason = "task frame 'bolt' is gone"
    assert b.start_next(cannot_start=lambda p: reason if p.frame == "bolt" else None) is fine
    assert (gone.status, gone.exit, gone.detail, gone.started_at) == ("done", "aborted", reason, None)


def test_the_queue_holds_its_cap_and_frees_a_place_as_one_starts() -> None:
    b = Book(queue_max=2)
    b.book.submit(PtwlParams())
    b.book.submit(PtwlParams())
    with pytest.raises(QueueFullError, match="command queue is full \\(2 queued\\)"):
        b.book.submit(PtwlParams())
    assert b.book.queued_count() == 2 and len(b.events) == 2  # the refused one left no trace
    b.start_next()
    b.book.submit(PtwlParams())
    assert b.book.queued_count() == 2


def test_stop_drops_the_queue_aborted_and_keeps_the_running_one_for_its_report() -> None:
    b = Book()
    running = b.book.submit(PtwlParams())
    queued = [b.book.submit(PtwlParams()) for _ in range(3)]
    b.start_next()
    dropped = b.book.drop_queued()
    assert dropped == queued and b.book.running is running and b.book.queued_count() == 0
    assert all((r.exit, r.detail) == ("aborted", "dropped by stop") for r in queued)
    assert b.start_next() is None  # nothing left, and the running one still runs


def test_a_machines_steps_are_announced_while_it_runs() -> None:
    b = Book()
    b.book.submit(PtwlParams())
    b.start_next()
    before = len(b.events)
    b.book.step_done(StepRecord(0, PtwlParams(), "approach", report_for(b)))
    assert b.events[before:] == [(1, "running", None)] and len(b.book.running.steps) == 1  # type: ignore[union-attr]
    b.book.finish(report_for(b))
    b.book.step_done(StepRecord(1, PtwlParams(), "late", report_for(b)))  # none running: ignored
    assert b.events[-1] == (1, "done", "goal_reached")


def test_sent_at_may_lead_the_books_clock_by_the_skew_and_no_more() -> None:
    b = Book(skew_s=5.0)
    b.book.submit(PtwlParams(sent_at=EPOCH_S + 5.0))
    with pytest.raises(FutureSentAtError, match=r"now is 1000\.000"):
        b.book.submit(PtwlParams(sent_at=EPOCH_S + 5.001))


def test_the_history_keeps_the_last_ended_commands_and_never_one_still_going() -> None:
    b = Book(history_max=3)
    first = b.book.submit(PtwlParams())
    for _ in range(3):
        b.book.submit(PtwlParams())
    assert b.book.record(first.id) is first  # over the bound, but still queued: kept
    b.book.drop_queued()
    b.book.submit(PtwlParams())
    assert b.book.record(first.id) is None and len(b.book.recent(10)) == 3
    assert [r.id for r in b.book.recent(2)] == [4, 5]


def test_frames_named_by_waiting_commands_are_known() -> None:
    b = Book()
    b.book.submit(PtwlParams(frame="bolt"))
    b.book.submit(PtwlParams(frame="tool"))
    b.book.submit(PtwlParams(frame="bolt", gains_frame="bolt"))
    b.start_next()
    assert b.book.naming_frame("bolt") == [1, 3] and b.book.naming_frame("nut") == []


def test_the_runner_starts_nothing_while_a_behavior_runs_outside_the_book() -> None:
    """The runner's own guard (the book's only knows its own running command): a behavior
    started on the simulation directly (`ptwl sim`, a test) is not preempted by the queue."""
    from robot_sim.behaviors import behavior_for
    from robot_sim.command_runner import CommandRunner
    from robot_sim.sim import Simulation

    sim = Simulation("free_space")
    runner = CommandRunner(sim, CommandBook(8, 16, FakeClock(EPOCH_S), instance="test"))
    outside = behavior_for(RweParams(duration=0.05))
    sim.start(outside)
    runner.book.submit(RweParams(duration=0.05))
    assert runner.start_next() is None and sim.behavior is outside
    while sim.behavior is not None:
        sim.step()
    started = runner.start_next()
    assert started is not None and started.id == 1 and sim.behavior is not outside

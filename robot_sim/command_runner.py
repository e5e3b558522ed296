"""A robot that runs the commands of a book (robot_sim/command_book.py) on a Simulation: the
next queued command starts when no behavior runs (checked against the task frames it names), a
behavior's end is the command's end or a state machine's step, STOP aborts the running command
and drops the queue. The real-time server (server/runner.py) and the sweeps' virtual robot
(ptwl/experiments/sweep/robot.py) both run commands through this, on their own clocks."""

from collections.abc import Callable
from dataclasses import dataclass

from robot_sim.behaviors import BehaviorReport
from robot_sim.command_book import CommandBook, CommandRecord
from robot_sim.executor import CommandExecutor, DecisionError, Ended
from robot_sim.machines.command import DecisionRequest, StateMachineParams
from robot_sim.policies.run import StepRecord
from robot_sim.sim import Simulation


@dataclass(frozen=True)
class Stopped:
    aborted: int | None  # the running command's id
    dropped: list[int]  # the queued commands' ids


class CommandRunner:
    def __init__(
        self, sim: Simulation, book: CommandBook, on_step: Callable[[int, StepRecord], None] | None = None
    ) -> None:
        self.sim = sim
        self.book = book
        self._executor = CommandExecutor(sim)
        self._on_step = on_step  # every behavior's end, by command id (a recording's steps)

    def start_next(self) -> CommandRecord | None:
        """Start the next queued command if no behavior runs; the one started."""
        if self.sim.behavior is not None:
            return None
        sim = self.sim
        started = self.book.start_next(
            lambda record: self._executor.start(record.params), sim.time, sim.frames.missing_reason
        )
        if started is not None and isinstance(started.params, StateMachineParams):
            self._note_machine(started)  # its view from the first step (telemetry reads it)
        return started

    def behavior_ended(self, report: BehaviorReport) -> tuple[CommandRecord | None, Ended]:
        """A behavior ended: the running command's end, or its state machine's step (announced
        as it ends; a behavior command's one step is the command itself, announced by its end).
        (The command it belonged to, what its end meant.)"""
        running = self.book.running
        ended = self._executor.behavior_ended(report)
        if running is not None and self._on_step is not None:
            self._on_step(running.id, ended.step)
        if running is not None and isinstance(running.params, StateMachineParams):
            self._note_machine(running)
            self.book.step_done(ended.step)
        if ended.command is not None:
            self.book.finish(ended.command)
        return running, ended

    def decide(self, command_id: int, request: DecisionRequest) -> CommandRecord:
        """The operator's decision for the running machine `command_id` (DecisionError if it is
        not running or not waiting for that decision); announced as a change of its record."""
        running = self.book.running
        if running is None or running.id != command_id:
            raise DecisionError("command", f"command {command_id} is not the running state machine")
        ended = self._executor.decide(request)
        self._note_machine(running)
        if ended.command is not None:
            self.book.finish(ended.command)
        else:
            self.book.changed(running)
        return running

    def scene_reloaded(self) -> None:
        """The physics faulted and the scene reloaded at t = 0: a machine that waited for a
        decision ends `fault` (a running behavior's fault ends it through its report)."""
        running = self.book.running
        if running is not None:
            self._end_waiting(running, self._executor.fault_waiting())

    def _end_waiting(self, running: CommandRecord, ended: Ended | None) -> None:
        if ended is not None:
            self._note_machine(running)
            assert ended.command is not None
            self.book.finish(ended.command)

    def machine_view(self) -> dict[str, object] | None:
        """The running machine's state, pending decision and decisions (telemetry's `machine`):
        its record's view, made once per change (a step's end, a decision), not per state sent."""
        running = self.book.running
        if running is None or running.machine is None or self._executor.run is None:
            return None
        return {"command": running.id, **running.machine}

    def _note_machine(self, record: CommandRecord) -> None:
        run = self._executor.run
        record.machine = run.view() if run is not None else self._executor.ended_view

    def stop_all(self) -> Stopped:
        """Abort the running command, drop the queue, hold the robot where it is."""
        dropped = self.book.drop_queued()
        running = self.book.running
        report = self.sim.hold_position()  # ends the running behavior `aborted`, "stopped"
        if report is not None:
            self.behavior_ended(report)
        elif running is not None:  # a machine waiting for a decision: no behavior runs
            self._end_waiting(running, self._executor.stop_waiting())
        return Stopped(running.id if running else None, [r.id for r in dropped])

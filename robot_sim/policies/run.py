"""Driving a policy: the one loop the headless runner and the server's `state_machine` command
share, and the paper's per-trial figures (Tables 1-3) from its steps."""

import statistics
from dataclasses import dataclass, field
from typing import Any

from robot_sim.behaviors import BehaviorParams, BehaviorReport, ExitCondition, Pose
from robot_sim.policies.base import Decision, Finish, Policy, Step


@dataclass(frozen=True)
class StepRecord:
    """One behavior the machine ran: what, why, and how it ended."""

    index: int
    params: BehaviorParams
    why: str
    report: BehaviorReport
    state: str = ""  # its state's name, in a machine written as data

    def as_dict(self) -> dict[str, Any]:
        r = self.report
        return {
            "index": self.index,
            "behavior": self.params.type,
            "params": self.params.model_dump(),
            "why": self.why,
            "state": self.state,
            "exit": r.exit.value,
            "started_at": r.started_at,
            "ended_at": r.ended_at,
            "peak_force": r.peak_force,
            "peak_torque": r.peak_torque,
            "final_wrench": list(r.final_wrench),
            "final_port": r.final_port.as_dict(),
            "detail": r.detail,
        }


@dataclass
class Machine:
    """A policy being run: the step in flight, the steps done, and how it ended."""

    policy: Policy
    steps: list[StepRecord] = field(default_factory=list)
    current: Step | None = None
    finish: Finish | None = None
    exit: ExitCondition | None = None  # completed, failed, aborted or fault, once ended

    def start(self, port: Pose) -> Step:
        self.current = self.policy.first(port)
        return self.current

    def advance(self, report: BehaviorReport) -> Step | None:
        """The running step ended with `report`: the next step, or None when the machine ended."""
        if self.record(report):
            return None
        return self.take(self.policy.next(report))

    def record(self, report: BehaviorReport) -> bool:
        """Keep the running step's `report`; True when that ended the machine (STOP, a fault):
        then nothing is left to decide."""
        assert self.current is not None, "record() before start()"
        self.steps.append(
            StepRecord(len(self.steps), self.current.params, self.current.why, report, self.current.state)
        )
        self.current = None
        if report.exit in (ExitCondition.ABORTED, ExitCondition.FAULT):  # STOP, or the physics
            why = f"step {len(self.steps)} ({report.behavior}) ended {report.exit}"
            self._end(Finish(False, why), report.exit)
            return True
        return False

    def take(self, decision: Decision) -> Step | None:
        """Act on the decision about the last step: the next step, or None when it ended."""
        if isinstance(decision, Finish):
            self._end(decision, ExitCondition.COMPLETED if decision.completed else ExitCondition.FAILED)
            return None
        if len(self.steps) >= self.policy.max_steps():
            self._end(Finish(False, f"still going after {len(self.steps)} behaviors"), ExitCondition.FAILED)
            return None
        self.current = decision
        return decision

    def stop(self, why: str, exit_condition: ExitCondition = ExitCondition.ABORTED) -> None:
        """Ended between steps: an operator's stop at a decision or STOP (`aborted`), or the
        physics faulting while a decision waited (`fault`)."""
        self._end(Finish(False, why), exit_condition)

    def _end(self, finish: Finish, exit_condition: ExitCondition) -> None:
        self.finish, self.exit = finish, exit_condition

    def report(self) -> BehaviorReport:
        """The whole run as one report (peak over every step; the last step's wrench and pose)."""
        assert self.exit is not None and self.finish is not None and self.steps
        first, last = self.steps[0].report, self.steps[-1].report
        return BehaviorReport(
            behavior="state_machine",
            exit=self.exit,
            started_at=first.started_at,
            ended_at=last.ended_at,
            peak_force=max(s.report.peak_force for s in self.steps),
            peak_torque=max(s.report.peak_torque for s in self.steps),
            final_wrench=last.final_wrench,
            final_port=last.final_port,
            detail=self.finish.why,
        )


def trial_metrics(steps: list[StepRecord]) -> dict[str, Any]:
    return report_metrics([s.report for s in steps])


def report_metrics(reports: list[BehaviorReport]) -> dict[str, Any]:
    """The paper's per-trial figures from the reports of every behavior run, in order: peaks,
    run time, behaviors by kind, PTWLs by exit (the gripper's closes and opens counted apart:
    not behaviors)."""
    ptwl_exits = [r.exit.value for r in reports if r.behavior == "ptwl"]
    return {
        "max_force_n": max((r.peak_force for r in reports), default=0.0),
        "max_torque_nm": max((r.peak_torque for r in reports), default=0.0),
        "run_time_s": reports[-1].ended_at - reports[0].started_at if reports else 0.0,
        "behaviors": sum(r.behavior != "gripper" for r in reports),
        "gripper": sum(r.behavior == "gripper" for r in reports),
        "rwe": sum(r.behavior == "rwe" for r in reports),
        "dither": sum(r.behavior == "dither" for r in reports),
        "ptwl": {
            exit.value: ptwl_exits.count(exit.value)
            for exit in (ExitCondition.TIMEOUT, ExitCondition.GOAL_REACHED, ExitCondition.WRENCH_BREACH)
        },
    }


def paper_rows(metrics: list[dict[str, Any]], successes: list[bool]) -> list[tuple[str, str]]:
    """The paper's Tables 1-3 layout over trials (each `metrics` in trial_metrics' shape):
    success, then the mean of each figure."""

    def mean(key: str) -> float:
        return statistics.fmean(m[key] for m in metrics)

    def mean_ptwl(exit_name: str) -> float:
        return statistics.fmean(m["ptwl"][exit_name] for m in metrics)

    return [
        ("Trials", f"{len(metrics)}"),
        ("Success", f"{sum(successes)} / {len(successes)}"),
        ("Max force [N]", f"{mean('max_force_n'):.1f}"),
        ("Max torque [N m]", f"{mean('max_torque_nm'):.2f}"),
        ("Run time [s]", f"{mean('run_time_s'):.1f}"),
        ("Number of behaviors", f"{mean('behaviors'):.2f}"),
        ("RWE", f"{mean('rwe'):.2f}"),
        ("PTWL (timeout)", f"{mean_ptwl('timeout'):.2f}"),
        ("PTWL (goal reached)", f"{mean_ptwl('goal_reached'):.2f}"),
        ("PTWL (wrench breach)", f"{mean_ptwl('wrench_breach'):.2f}"),
        ("Dither", f"{mean('dither'):.2f}"),
        ("Gripper (not a behavior)", f"{mean('gripper'):.2f}"),
    ]

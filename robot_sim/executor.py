"""Running one command on a Simulation: a behavior, or a state machine stepping onboard.

The one rule for what a command does on the robot, shared by the real-time server
(server/runner.py) and the virtual-time sweeps (ptwl/experiments/sweep): a behavior command starts
its behavior; a `state_machine` command starts its machine's first step and, each time a step
ends, decides the next one in the same control tick (onboard: no link in between), unless the
transition's autonomy level says the operator decides (robot_sim/machines/spec.py, `waits`):
then nothing starts and the attractor stays where the step left it (the port keeps pressing as it
was, no drift) until a decision arrives (`decide`). STOP and faults end a machine too: it is
told, and ends `aborted` or `fault`.
"""

from dataclasses import dataclass, field
from typing import Any

from robot_sim.behaviors import BehaviorParams, BehaviorReport, behavior_for
from robot_sim.behaviors.base import Pose
from robot_sim.errors import RobotSimError
from robot_sim.machines.command import DecisionRequest, StateMachineParams
from robot_sim.machines.engine import Proposal, SpecPolicy, policy_class
from robot_sim.machines.spec import waits
from robot_sim.policies import Machine, policy_for
from robot_sim.policies.base import Decision
from robot_sim.policies.run import StepRecord
from robot_sim.sim import Simulation

CommandParams = BehaviorParams | StateMachineParams
HISTORY_MAX = 200  # decisions kept per machine for telemetry (a run's whole list is in its steps)


class DecisionError(RobotSimError):
    """A decision that cannot be taken now (none pending, another one's, an unknown state)."""

    def __init__(self, field_name: str, message: str) -> None:
        super().__init__(message)
        self.field = field_name


@dataclass
class Pending:
    """A decision waiting for the operator: the proposal, the report it is about, since when."""

    number: int
    proposal: Proposal
    report: BehaviorReport
    asked_at: float  # [s] sim time
    next_params: dict[str, Any] | None  # the proposed next behavior's parameters (None: it ends)

    def as_dict(self) -> dict[str, Any]:
        r = self.report
        return {
            "decision": self.number,
            **self.proposal.as_dict(),
            "asked_at": self.asked_at,
            "next": self.next_params,
            "report": {
                "behavior": r.behavior,
                "exit": r.exit.value,
                "peak_force": r.peak_force,
                "peak_torque": r.peak_torque,
                "final_wrench": list(r.final_wrench),
                "detail": r.detail,
            },
        }


@dataclass
class MachineRun:
    """A running state machine command: the machine, its autonomy, its decisions."""

    machine: Machine
    autonomy: str
    name: str
    pending: Pending | None = None
    asked: int = 0  # decisions that waited for the operator
    waited_s: float = 0.0  # [s] sim time spent waiting, in total
    history: list[dict[str, Any]] = field(default_factory=list)

    @property
    def spec_policy(self) -> SpecPolicy | None:
        policy = self.machine.policy
        return policy if isinstance(policy, SpecPolicy) else None

    def view(self) -> dict[str, Any]:
        """What telemetry says about it: state, pending decision, decisions so far."""
        policy = self.spec_policy
        current = self.machine.current
        return {
            "name": self.name,
            "autonomy": self.autonomy,
            "state": policy.state if policy is not None else (current.state if current else ""),
            "steps": len(self.machine.steps),
            "visits": dict(policy.visits) if policy is not None else {},
            "pending": self.pending.as_dict() if self.pending is not None else None,
            "decisions_waited": self.asked,
            "waited_s": self.waited_s,
            "history": self.history[-20:],
        }


@dataclass(frozen=True)
class Ended:
    """What a behavior's end meant for the command: the step it was (a machine's, or a behavior
    command's only one) and, when the command is over, its report (a machine's whole run as
    one report)."""

    step: StepRecord
    command: BehaviorReport | None


class CommandExecutor:
    def __init__(self, sim: Simulation) -> None:
        self.sim = sim
        self.run: MachineRun | None = None  # the running state machine command's, if any
        self.ended_view: dict[str, Any] | None = None  # the last machine's view as it ended
        self._behavior: BehaviorParams | None = None  # the running behavior command's, if any

    @property
    def machine(self) -> Machine | None:
        return self.run.machine if self.run is not None else None

    def start(self, params: CommandParams) -> Pose | None:
        """Start a command now; the absolute goal it resolved (a PTWL's), if it has one."""
        if isinstance(params, StateMachineParams):
            spec = params.spec()
            policy = (
                policy_class(spec)(params.overrides)
                if spec
                else policy_for(str(params.task), params.overrides)
            )
            name = spec.name if spec else str(params.task)
            self.run = MachineRun(Machine(policy), params.autonomy, name)
            self.sim.start(behavior_for(self.run.machine.start(self.sim.state().port).params))
            return None
        behavior = behavior_for(params)
        self._behavior = params
        self.sim.start(behavior)
        return behavior.goal_pose()

    def behavior_ended(self, report: BehaviorReport) -> Ended:
        run = self.run
        if run is None:
            assert self._behavior is not None, "a behavior ended that no command started"
            params, self._behavior = self._behavior, None
            return Ended(StepRecord(0, params, "", report), report)
        machine = run.machine
        if machine.record(report):
            return self._over(run)
        policy = run.spec_policy
        if policy is None:
            return self._go(run, policy_decision=machine.policy.next(report))
        proposal = policy.propose(report)
        if waits(proposal.level, run.autonomy):  # type: ignore[arg-type]
            run.asked += 1
            run.pending = Pending(
                run.asked, proposal, report, self.sim.time, policy.preview(proposal, report)
            )
            return Ended(machine.steps[-1], None)
        self._log(run, proposal, "autonomous", 0.0)
        return self._go(run, policy.commit(proposal, report))

    def decide(self, request: DecisionRequest) -> Ended:
        """The operator's answer to the pending decision (DecisionError if it is not one)."""
        run = self.run
        pending = run.pending if run is not None else None
        if run is None or pending is None:
            raise DecisionError(
                "decision", f"no decision is pending (decision {request.decision} was asked for)"
            )
        if request.decision != pending.number:
            raise DecisionError(
                "decision", f"decision {request.decision} is not the pending one ({pending.number})"
            )
        policy = run.spec_policy
        assert policy is not None  # only machines written as data wait
        waited = self.sim.time - pending.asked_at
        if request.choice == "stop":
            run.pending = None
            run.waited_s += waited
            self._log(run, pending.proposal, "stop", waited)
            run.machine.stop(
                f"stopped by the operator at decision {pending.number} ({pending.proposal.state})"
            )
            return self._over(run)
        if request.choice == "force":
            try:
                proposal = policy.force(str(request.state), pending.report)
            except KeyError:
                raise DecisionError("state", f"no state {request.state!r} in {run.name}") from None
        elif request.choice == "outcome":
            proposal = policy.propose(pending.report, request.outcome)
        else:
            proposal = pending.proposal
        run.pending = None
        run.waited_s += waited
        self._log(run, proposal, request.choice, waited)
        return self._go(run, policy.commit(proposal, pending.report))

    def stop_waiting(self) -> Ended | None:
        """STOP while a decision waits: the machine ends `aborted` (no behavior runs to abort)."""
        run = self.run
        if run is None or run.pending is None:
            return None
        pending = run.pending
        run.pending = None
        run.machine.stop(f"stopped while decision {pending.number} waited ({pending.proposal.state})")
        return self._over(run)

    # ------------------------------------------------------------------ parts
    def _go(self, run: MachineRun, policy_decision: Decision) -> Ended:
        step = run.machine.take(policy_decision)
        if step is not None:
            self.sim.start(behavior_for(step.params))
            return Ended(run.machine.steps[-1], None)
        return self._over(run)

    def _over(self, run: MachineRun) -> Ended:
        self.run = None
        self.ended_view = run.view()
        return Ended(run.machine.steps[-1], run.machine.report())

    @staticmethod
    def _log(run: MachineRun, proposal: Proposal, how: str, waited_s: float) -> None:
        entry = {**proposal.as_dict(), "how": how, "waited_s": waited_s}
        run.history.append(entry)
        del run.history[:-HISTORY_MAX]

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

from collections import deque
from dataclasses import dataclass, field
from typing import Any

from robot_sim.behaviors import BehaviorParams, BehaviorReport, behavior_for
from robot_sim.behaviors.base import ExitCondition, Pose
from robot_sim.errors import RobotSimError
from robot_sim.machines.command import DecisionRequest, StateMachineParams
from robot_sim.machines.engine import Proposal, SpecPolicy, policy_class
from robot_sim.machines.spec import TERMINALS, Autonomy, waits
from robot_sim.policies import Machine, policy_for
from robot_sim.policies.base import Decision
from robot_sim.policies.run import StepRecord
from robot_sim.sim import Simulation

CommandParams = BehaviorParams | StateMachineParams
HISTORY_MAX = 20  # the last decisions a machine's view keeps (telemetry, the record); its steps are all


class DecisionError(RobotSimError):
    """A decision that is not the robot's to take now: no machine waits, or for another one (409)."""

    def __init__(self, field_name: str, message: str) -> None:
        super().__init__(message)
        self.field = field_name


class DecisionInvalid(DecisionError, ValueError):
    """A decision naming what the machine does not have: an exit its state's behavior never ends
    with, a state it has no such (422)."""


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
    autonomy: Autonomy
    name: str
    pending: Pending | None = None
    asked: int = 0  # decisions that waited for the operator
    waited_s: float = 0.0  # [s] sim time spent waiting, in total
    history: deque[dict[str, Any]] = field(default_factory=lambda: deque(maxlen=HISTORY_MAX))

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
            "history": list(self.history),
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
        if waits(proposal.level, run.autonomy):
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
        # Checked before anything changes: a refused decision leaves the wait as it was.
        if request.choice == "force":
            try:
                proposal = policy.force(str(request.state), pending.report)
            except KeyError:
                states = ", ".join([*policy.spec.states, *TERMINALS])
                raise DecisionInvalid(
                    "state", f"no state {request.state!r} in {run.name} ({states})"
                ) from None
        elif request.choice == "outcome":
            exits = policy.spec.states[pending.proposal.state].exits()
            if request.outcome not in exits:
                raise DecisionInvalid(
                    "outcome",
                    f"a {pending.report.behavior} in state {pending.proposal.state} ends "
                    f"{', '.join(exits)}, not {request.outcome!r}",
                )
            proposal = policy.propose(pending.report, request.outcome)
        else:
            proposal = pending.proposal
        run.pending = None
        run.waited_s += waited
        self._log(run, proposal, request.choice, waited)
        return self._go(run, policy.commit(proposal, pending.report))

    def stop_waiting(self) -> Ended | None:
        """STOP while no behavior runs (a decision waits): the machine ends `aborted`."""
        return self._end_between_steps("stopped", ExitCondition.ABORTED)

    def fault_waiting(self) -> Ended | None:
        """The physics faulted (the scene reloaded) while no behavior ran: a machine waiting
        for a decision ends `fault`; it never goes on in the fresh scene."""
        return self._end_between_steps("the physics faulted", ExitCondition.FAULT)

    def _end_between_steps(self, what: str, exit_condition: ExitCondition) -> Ended | None:
        run = self.run
        if run is None or self.sim.behavior is not None:
            return None
        pending = run.pending
        run.pending = None
        where = (
            f"while decision {pending.number} waited ({pending.proposal.state})"
            if pending
            else "between steps"
        )
        run.machine.stop(f"{what} {where}", exit_condition)
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
        run.history.append({**proposal.as_dict(), "how": how, "waited_s": waited_s})

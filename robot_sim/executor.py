"""Running one command on a Simulation: a behavior, or a task's state machine stepping at once.

The one rule for what a command does on the robot, shared by the real-time server
(server/runner.py) and the virtual-time sweeps (ptwl/experiments/sweep): a behavior command starts
its behavior; a `state_machine` command starts its machine's first step and, each time a step
ends, the next one in the same control tick (onboard: no link in between). STOP and faults end a
machine too: it is told, and ends `aborted` or `fault`.
"""

from dataclasses import dataclass

from robot_sim.behaviors import BehaviorParams, BehaviorReport, behavior_for
from robot_sim.behaviors.base import Pose
from robot_sim.params import StateMachineParams
from robot_sim.policies import Machine, policy_for
from robot_sim.policies.run import StepRecord
from robot_sim.sim import Simulation

CommandParams = BehaviorParams | StateMachineParams


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
        self.machine: Machine | None = None  # the running state machine command's, if any
        self._behavior: BehaviorParams | None = None  # the running behavior command's, if any

    def start(self, params: CommandParams) -> Pose | None:
        """Start a command now; the absolute goal it resolved (a PTWL's), if it has one."""
        if isinstance(params, StateMachineParams):
            self.machine = Machine(policy_for(params.task, params.overrides))
            self.sim.start(behavior_for(self.machine.start(self.sim.state().port).params))
            return None
        behavior = behavior_for(params)
        self._behavior = params
        self.sim.start(behavior)
        return behavior.goal_pose()

    def behavior_ended(self, report: BehaviorReport) -> Ended:
        machine = self.machine
        if machine is None:
            assert self._behavior is not None, "a behavior ended that no command started"
            params, self._behavior = self._behavior, None
            return Ended(StepRecord(0, params, "", report), report)
        step = machine.advance(report)
        if step is not None:
            self.sim.start(behavior_for(step.params))
            return Ended(machine.steps[-1], None)
        self.machine = None
        return Ended(machine.steps[-1], machine.report())

"""Onboard state machines, one per task, built only from PTWL, RWE and Dither (paper 2.3).

`policy_for(task)` gives a fresh policy (base.py); `run_onboard` runs one headless on a fresh
simulation of the task's scene, each next step at once, as fast as the CPU allows, and judges
the result by the scene's own predicate, which the policy never sees.
"""

from dataclasses import dataclass
from typing import Any

import robot_sim.presets  # noqa: F401  (registered first: the steps below name its presets)
from robot_sim.behaviors import behavior_for
from robot_sim.errors import UnknownNameError
from robot_sim.machines.engine import policy_class
from robot_sim.machines.library import builtin_machines
from robot_sim.machines.spec import MachineSpec
from robot_sim.params import NAMED
from robot_sim.policies.base import Decision, Finish, Policy, Step
from robot_sim.policies.lid import Lid
from robot_sim.policies.run import Machine, StepRecord, trial_metrics
from robot_sim.policies.sleeve_on_peg import SleeveOnPeg
from robot_sim.policies.tool_exchange import ToolExchange
from robot_sim.sim import Simulation

# Python: the machines the format cannot express (README: Machines says why); the rest are files.
PYTHON_POLICIES: dict[str, type[Policy]] = {p.task: p for p in (SleeveOnPeg, Lid, ToolExchange)}
_FILES: dict[str, type[Policy]] = {task: policy_class(spec) for task, spec in builtin_machines().items()}
# The paper's order (section 2.3's), as the API and the console list them.
ORDER = (
    "sleeve_on_peg",
    "quick_connect",
    "lid",
    "plug",
    "socket_wrench",
    "door",
    "berthing",
    "tool_retrieval",
    "tool_stowage",
    "tool_exchange",
)
POLICIES: dict[str, type[Policy]] = {task: {**PYTHON_POLICIES, **_FILES}[task] for task in ORDER}

# The tasks a request names are these (robot_sim/params.py resolves names through NAMED).
NAMED.tasks = POLICIES.keys
NAMED.task_settings = lambda task: POLICIES[task].settings_model


def policy_for(task: str, overrides: dict[str, object] | None = None) -> Policy:
    """A fresh policy for `task`, its settings overridden (checked: pydantic.ValidationError)."""
    try:
        policy = POLICIES[task]
    except KeyError:
        raise UnknownNameError("task", task, list(POLICIES)) from None
    return policy(overrides)


@dataclass(frozen=True)
class TaskRun:
    """One headless trial: the predicate's verdict, the machine's, and the paper's figures."""

    task: str
    seed: int | None
    success: bool  # the scene's predicate at the end
    progress: float
    unit: str
    end: str  # the machine's exit: completed, failed, aborted or fault
    why: str
    sim_time_s: float
    steps: list[StepRecord]
    figures: dict[str, float]  # the machine's own beyond the paper's (a tool exchange's cycles)

    def as_dict(self) -> dict[str, Any]:
        return {
            "task": self.task,
            "seed": self.seed,
            "success": self.success,
            "progress": self.progress,
            "unit": self.unit,
            "end": self.end,
            "why": self.why,
            "sim_time_s": self.sim_time_s,
            **trial_metrics(self.steps),
            **self.figures,
            "steps": [s.as_dict() for s in self.steps],
        }


def run_onboard(
    task: str,
    seed: int | None = None,
    sim: Simulation | None = None,
    overrides: dict[str, object] | None = None,
    gripper_close_s: float | None = None,
    machine: MachineSpec | None = None,
) -> TaskRun:
    """Run `task`'s state machine (or `machine`, written as data) on `sim` (default: a fresh one
    of the task's scene, `seed`, its gripper closing with time constant `gripper_close_s`)."""
    if sim is not None and gripper_close_s is not None:
        raise ValueError("gripper_close_s is the scene's: give it to the Simulation passed in, not here")
    policy = policy_class(machine)(overrides) if machine is not None else policy_for(task, overrides)
    running = Machine(policy)
    sim = sim or Simulation(task, seed, gripper_close_s=gripper_close_s)
    step: Step | None = running.start(sim.state().port)
    while step is not None:
        step = running.advance(sim.run_behavior(behavior_for(step.params)))
    assert running.exit is not None and running.finish is not None
    verdict = sim.task()
    return TaskRun(
        task,
        seed,
        verdict.success,
        verdict.progress,
        verdict.unit,
        running.exit.value,
        running.finish.why,
        sim.time,
        running.steps,
        running.policy.figures(),
    )


__all__ = [
    "POLICIES",
    "Decision",
    "Finish",
    "Machine",
    "Policy",
    "Step",
    "TaskRun",
    "policy_for",
    "run_onboard",
]

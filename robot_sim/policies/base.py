"""A task's onboard state machine, written as a policy (paper 2.1: "the subsequent state depends
on the exit condition returned by the behavior").

A policy sees only what a behavior reports (its exit, the wrench and port pose at exit) and
what it has itself remembered; from that it chooses the next behavior, or finishes. It holds no
simulation, server or clock: the same policy runs onboard, the next step at once (`run.py`, the
server's `state_machine` command), or on the ground, each report arriving down a delayed link.
"""

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import ClassVar

from pydantic import Field

from robot_sim.behaviors import BehaviorParams, BehaviorReport, Pose
from robot_sim.params import StrictModel


@dataclass(frozen=True)
class Step:
    """Run this behavior next, for this reason."""

    params: BehaviorParams
    why: str
    state: str = ""  # the state it is, in a machine whose states have names (robot_sim/machines)


@dataclass(frozen=True)
class Finish:
    """The machine's own verdict: it believes the task done (`completed`) or gives up (`failed`).
    The scene's predicate, which the policy cannot see, is judged separately."""

    completed: bool
    why: str


Decision = Step | Finish
MAX_STEPS = 60  # behaviors; a task's machine still going after this many has lost its way


class PolicySettings(StrictModel):
    """What a `state_machine` command may override (its `overrides`); each policy adds its own."""

    max_recoveries: int = Field(3, ge=0, le=10, description="recovery rounds before it gives up")


class Policy(ABC):
    """One task's state machine; a fresh instance per run (it keeps the run's memory)."""

    task: str  # the task, and the scene it runs on
    summary: str  # its procedure in a line
    settings_model: ClassVar[type[PolicySettings]] = PolicySettings
    settings: PolicySettings

    def __init__(self, overrides: dict[str, object] | None = None) -> None:
        """`overrides` checked against `settings_model` (a 422 names the field on the API)."""
        self.settings = self.settings_model.model_validate(overrides or {})

    @abstractmethod
    def first(self, port: Pose) -> Step:
        """The opening behavior, given where the port is at the start (base frame)."""

    @abstractmethod
    def next(self, report: BehaviorReport) -> Decision:
        """Given how the last behavior ended, the next step or the end."""

    def max_steps(self) -> int:
        """Behaviors after which the machine has lost its way (it ends `failed`): a bound on
        what a run can record."""
        return MAX_STEPS

    def figures(self) -> dict[str, float]:
        """Per-trial figures of the machine's own beyond the paper's (a count of cycles)."""
        return {}


class StagedPolicy(Policy):
    """A policy that names its steps: `last` is the one whose report comes next, `start` where
    the port was when the machine began (what depth, swing and turn are measured from)."""

    def __init__(self, overrides: dict[str, object] | None = None) -> None:
        super().__init__(overrides)
        self.home: Pose | None = None
        self.last = ""

    def first(self, port: Pose) -> Step:
        self.home = port
        return self.opening()

    @abstractmethod
    def opening(self) -> Step:
        """The first step (through `stage`, so that it is named)."""

    def stage(self, name: str, params: BehaviorParams, why: str) -> Step:
        self.last = name
        return Step(params, why)

    @property
    def start(self) -> Pose:
        assert self.home is not None, "next() before first()"
        return self.home

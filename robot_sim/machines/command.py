"""The `state_machine` command: a task's built-in machine or one written as data, run onboard
as one command, at an autonomy level (FlexBE's): a transition whose level is not below it waits
for the operator's decision, which travels the link like any command."""

from typing import Any, Literal, Self

from pydantic import Field, ValidationError, field_validator, model_validator

from robot_sim.machines.engine import settings_model
from robot_sim.machines.library import builtin_machines
from robot_sim.machines.spec import AUTONOMY_LEVELS, TERMINALS, Autonomy, Exit, MachineSpec, Name
from robot_sim.params import NAMED, Expiring, StrictModel

AUTONOMY_DOC = (
    "FlexBE's levels off < low < high < full: a transition waits for the operator's decision "
    "unless its level is below this (`off`: every decision waits; a transition at `full` always "
    "does). Only machines written as data have levels (GET /api/tasks says which tasks' do)"
)


class StateMachineParams(Expiring):
    """A task's onboard state machine, or one given whole (`machine`), run as one command."""

    type: Literal["state_machine"] = Field("state_machine", description="command: state_machine")
    task: str | None = Field(
        None, description="which task's built-in machine (GET /api/tasks lists them); or give `machine`"
    )
    machine: MachineSpec | None = Field(
        None, description="a whole machine (README: Machines); its `task` names the scene it needs"
    )
    autonomy: Autonomy = Field("full", description=AUTONOMY_DOC)
    overrides: dict[str, Any] = Field(
        default_factory=dict,
        description="the machine's settings to change, e.g. {\"max_recoveries\": 0}; each task's "
        "settings and ranges are in GET /api/tasks",
    )

    @field_validator("task")
    @classmethod
    def _known(cls, task: str | None) -> str | None:
        tasks = sorted(NAMED.need(NAMED.tasks, "tasks")())
        if task is not None and task not in tasks:
            raise ValueError(f"task must be one of {', '.join(tasks)}, got {task!r}")
        return task

    @model_validator(mode="after")
    def _one_machine(self) -> Self:
        if (self.task is None) == (self.machine is None):
            raise ValueError(
                "give either task (a built-in machine) or machine (a whole one), not both or neither"
            )
        spec = self.spec()
        if spec is None and self.autonomy != "full":
            raise ValueError(
                f"autonomy: the {self.task} machine is Python (its decisions have no levels); "
                "it runs at `full` only"
            )
        name = spec.name if spec is not None else str(self.task)
        model = (
            settings_model(spec) if spec is not None else NAMED.need(NAMED.task_settings, "tasks")(self.task)
        )
        try:
            settings = model.model_validate(self.overrides)
        except ValidationError as err:
            said = "; ".join(f"{'.'.join(map(str, e['loc']))}: {e['msg']}" for e in err.errors())
            raise ValueError(f"overrides for {name}: {said}") from None
        if spec is not None:  # its commands as these settings fill them in
            problems = list(spec.command_problems(settings.model_dump()))
            if problems:
                raise ValueError(f"with these overrides, {name}: " + "; ".join(problems))
        return self

    def spec(self) -> MachineSpec | None:
        """The machine as data (given, or the task's built-in file), None for a Python one."""
        return self.machine or builtin_machines().get(self.task or "")

    def scene(self) -> str | None:
        """The scene it needs: its task's, or the one its machine names (None: any)."""
        return self.task or (self.machine.task if self.machine is not None else None)


class DecisionRequest(StrictModel):
    """The operator's answer to a pending decision of a running machine."""

    decision: int = Field(
        ge=1,
        le=1_000_000,
        description="which decision (the pending one's number): a late answer to an earlier one is refused",
    )
    choice: Literal["confirm", "outcome", "force", "stop"] = Field(
        description="confirm the proposed transition; `outcome`: decide as if the behavior had ended "
        "with `outcome`; `force`: go to `state` whatever the report says; stop: end the machine `aborted`"
    )
    outcome: Exit | None = Field(None, description="with choice `outcome`: the exit to decide by")
    state: Name | None = Field(
        None, description=f"with choice `force`: a state of the machine, or {' / '.join(TERMINALS)}"
    )

    @model_validator(mode="after")
    def _complete(self) -> Self:
        if (self.choice == "outcome") != (self.outcome is not None):
            raise ValueError("outcome: give it with choice `outcome`, and only then")
        if (self.choice == "force") != (self.state is not None):
            raise ValueError("state: give it with choice `force`, and only then")
        return self


__all__ = ["AUTONOMY_LEVELS", "DecisionRequest", "StateMachineParams"]

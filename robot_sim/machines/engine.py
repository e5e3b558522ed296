"""Running a MachineSpec: the one engine for every machine written as data, built-in or an
operator's. It is a Policy (robot_sim/policies/base.py), so it runs wherever a task's machine
runs: onboard in a `state_machine` command, headless in `ptwl task`, on the ground in a sweep.

Deciding is split in two so an operator can stand between them (autonomy levels): `propose`
reads the report and picks the transition without changing anything; `commit` takes it (sets
the state's variables, counts the visit, fills in the next command's numbers). `next`, the
Policy's, is both at once.
"""

from collections import Counter
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
from pydantic import BaseModel, Field, ValidationError, create_model

from robot_sim.behaviors import BehaviorReport, Pose
from robot_sim.machines.spec import (
    MAX_MACHINE_STEPS,
    START_POSE,
    TERMINALS,
    Autonomy,
    Guard,
    MachineSpec,
    Reading,
    Ref,
    command_params,
    command_refusals,
)
from robot_sim.params import AXIS_NAMES, StrictModel
from robot_sim.policies.base import Decision, Finish, Policy, Step
from robot_sim.policies.travel import tool_axis_tilt_rad, twist_about_tool_axis_rad
from robot_sim.pose_math import rotation_matrix


@dataclass(frozen=True)
class Proposal:
    """What the machine would do after `state` ended `exit`: the transition it picked (None:
    forced by the operator) and where it leads, with the readings that decided it."""

    state: str
    exit: str
    transition: int | None
    target: str  # a state, or `completed` / `failed`
    level: Autonomy
    readings: dict[str, float | str] = field(default_factory=dict)
    why: str = ""  # the transition's own words
    used_up: str | None = None  # the state it led to, whose visits were used up (then `target`)

    def as_dict(self) -> dict[str, Any]:
        return {
            "state": self.state,
            "exit": self.exit,
            "transition": self.transition,
            "target": self.target,
            "level": self.level,
            "readings": self.readings,
            "why": self.why,
            "used_up": self.used_up,
        }


def settings_model(spec: MachineSpec) -> type[BaseModel]:
    """The model a run's `overrides` are checked against: each setting in its [min, max]."""
    fields: dict[str, Any] = {
        name: (float, Field(s.value, ge=s.min, le=s.max, description=s.description))
        for name, s in spec.settings.items()
    }
    return create_model(f"{spec.name}_settings", __base__=StrictModel, **fields)


class SpecPolicy(Policy):
    """A MachineSpec being run: its variables, visits and current state."""

    spec: ClassVar[MachineSpec]

    def __init__(self, overrides: dict[str, object] | None = None) -> None:
        super().__init__(overrides)
        self.numbers: dict[str, float] = dict(self.settings.model_dump())
        self.poses: dict[str, Pose] = {}
        self.visits: Counter[str] = Counter()
        self.state = self.spec.start

    # --------------------------------------------------------------- Policy
    def first(self, port: Pose) -> Step:
        self.poses[START_POSE] = port
        step = self._enter(self.spec.start, "")
        # The start's command reads settings only (spec.py, _read_before_set), checked with the
        # run's overrides before it was accepted (command.py): it always fills in.
        assert isinstance(step, Step), step
        return step

    def next(self, report: BehaviorReport) -> Decision:
        return self.commit(self.propose(report), report)

    def max_steps(self) -> int:
        """Every state's visits (one for an unbounded one) and the usual margin, at most
        MAX_MACHINE_STEPS: what a machine from a request can make the robot run and record."""
        bounded = [self.spec.visits_allowed(n, self.numbers) for n in self.spec.states]
        return min(MAX_MACHINE_STEPS, sum(b or 1 for b in bounded) + super().max_steps())

    # ------------------------------------------------------------- deciding
    def propose(self, report: BehaviorReport, exit_name: str | None = None) -> Proposal:
        """The transition the report (its exit replaced by `exit_name`, an operator's other
        outcome) takes; nothing changes."""
        exit_name = exit_name or report.exit.value
        state = self.spec.states[self.state]
        numbers, poses = self._kept(report)
        readings: dict[str, float | str] = {}  # every guard read on the way, for the record
        for i, t in enumerate(state.transitions):
            if not t.takes(exit_name):
                continue
            for g in t.when:
                readings.setdefault(g.label, self._read(g, report, numbers, poses))
            if all(_holds(g, readings[g.label], numbers) for g in t.when):
                target = self._resolve(t.to)
                used_up = t.to if target != t.to else None
                return Proposal(self.state, exit_name, i, target, t.autonomy, readings, t.why, used_up)
        # Validation guarantees an unconditional transition for every exit the behavior ends
        # with; an operator's other outcome may name one it does not: the machine fails.
        return Proposal(self.state, exit_name, None, "failed", "off")

    def force(self, target: str, report: BehaviorReport) -> Proposal:
        """The operator's choice of the next state, whatever the report says."""
        if target not in self.spec.states and target not in TERMINALS:
            raise KeyError(target)
        return Proposal(self.state, report.exit.value, None, target, "off")

    def commit(self, proposal: Proposal, report: BehaviorReport) -> Decision:
        """Take `proposal`: keep the state's variables, enter the target (or finish)."""
        self.numbers, self.poses = self._kept(report)
        how = f"{proposal.state} ended {proposal.exit}"
        if proposal.readings:
            how += " (" + ", ".join(f"{k} {_shown(v)}" for k, v in proposal.readings.items()) + ")"
        if proposal.used_up is not None:
            allowed = self.spec.visits_allowed(proposal.used_up, self.numbers)
            how += f"; {proposal.used_up} used its {allowed} visits"
        if proposal.transition is None and proposal.target != "failed":
            how += ", forced by the operator"
        if proposal.target in TERMINALS:
            meaning = proposal.why if proposal.why and proposal.used_up is None else proposal.target
            return Finish(proposal.target == "completed", f"{how}: {meaning}")
        return self._enter(proposal.target, how, proposal.why if proposal.used_up is None else "")

    def preview(self, proposal: Proposal, report: BehaviorReport) -> dict[str, Any] | None:
        """The parameters of the behavior `proposal` leads to (None when it ends the machine)."""
        if proposal.target in TERMINALS:
            return None
        numbers, _ = self._kept(report)
        try:
            params = command_params(self.spec.states[proposal.target].command, numbers.__getitem__)
        except (ValidationError, KeyError, OverflowError):
            return None  # it cannot be filled in: committing it ends the machine, saying why
        return dict(params.model_dump())

    # ----------------------------------------------------------------- parts
    def _enter(self, name: str, how: str, meaning: str = "") -> Decision:
        """Into state `name`: its command filled in; a value the robot's rules refuse (a
        variable read from a report, out of range) ends the machine `failed`, saying which."""
        state = self.spec.states[name]
        try:
            params = command_params(state.command, self.numbers.__getitem__)
        except (ValidationError, KeyError, OverflowError) as err:
            return Finish(
                False, f"{how}: {name}'s command cannot be filled in: {_refusal(err, state.behavior)}"
            )
        self.state = name
        self.visits[name] += 1
        why = f"{state.why} ({how})" if how and state.why else (state.why or how)
        return Step(params, f"{meaning}: {why}" if meaning else why, name)

    def _resolve(self, target: str) -> str:
        """`target`, or where it leads once its visits are used up (followed on; bounded)."""
        for _ in range(len(self.spec.states) + 1):
            allowed = self.spec.visits_allowed(target, self.numbers) if target in self.spec.states else None
            if allowed is None or self.visits[target] < allowed:
                return target
            target = self.spec.states[target].exhausted
        return "failed"

    def _kept(self, report: BehaviorReport) -> tuple[dict[str, float], dict[str, Pose]]:
        """The variables once the current state's `set` has read `report` (new dicts)."""
        numbers, poses = dict(self.numbers), dict(self.poses)
        for var, keep in self.spec.states[self.state].set.items():
            if keep.is_pose:
                poses[var] = report.final_port
            else:
                value = self._read(keep, report, numbers, poses)
                assert isinstance(value, float)  # Keep has no text measure
                numbers[var] = value
        return numbers, poses

    def _read(
        self, r: Reading, report: BehaviorReport, numbers: dict[str, float], poses: dict[str, Pose]
    ) -> float | str:
        now = report.final_port
        match r.measure:
            case "travel":
                since = poses[r.since]
                axis_index = "xyz".index(r.axis)
                if r.frame == "tool":
                    axis = rotation_matrix(np.asarray(since.quaternion))[:, axis_index]
                else:
                    axis = np.eye(3)[axis_index]
                return float(axis @ (np.asarray(now.position) - np.asarray(since.position)))
            case "tilt":
                return tool_axis_tilt_rad(poses[r.since], now)
            case "twist":
                return twist_about_tool_axis_rad(poses[r.since], now)
            case "peak_force":
                return report.peak_force
            case "peak_torque":
                return report.peak_torque
            case "wrench":
                return float(report.final_wrench[AXIS_NAMES.index(r.axis)])
            case "visits":
                assert r.state is not None
                return float(self.visits[r.state])
            case "detail":
                return report.detail
            case _:
                assert r.var is not None
                return numbers[r.var]


def _refusal(err: Exception, behavior: str) -> str:
    """What refused a command as it was filled in, naming the field."""
    if isinstance(err, ValidationError):
        return "; ".join(f"{field}: {message}" for field, message in command_refusals(err, behavior))
    if isinstance(err, KeyError):
        return f"variable {err.args[0]!r} not set yet"
    return str(err)


def _shown(value: float | str) -> str:
    return repr(value[:60]) if isinstance(value, str) else f"{value:.4g}"


def _holds(guard: Guard, reading: float | str, numbers: dict[str, float]) -> bool:
    value = guard.value
    if guard.op == "starts_with":
        assert isinstance(reading, str) and isinstance(value, str)
        return reading.startswith(value)
    assert isinstance(reading, float)
    bound = numbers[value.var] * value.scale + value.offset if isinstance(value, Ref) else float(value)
    match guard.op:
        case "<":
            return reading < bound
        case "<=":
            return reading <= bound
        case ">":
            return reading > bound
        case _:
            return reading >= bound


def policy_class(spec: MachineSpec) -> type[SpecPolicy]:
    """A Policy class running `spec` (a fresh instance per run, as every task's)."""
    return type(
        f"Machine_{spec.name}",
        (SpecPolicy,),
        {
            "spec": spec,
            "task": spec.task or spec.name,
            "summary": spec.summary or f"the machine {spec.name!r}",
            "settings_model": settings_model(spec),
        },
    )

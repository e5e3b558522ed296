"""An onboard state machine as data: the one model that validates a TOML file and the JSON of a
`state_machine` command's `machine` (paper 2.1: "the subsequent state depends on the exit
condition returned by the behavior"; FlexBE's operator-authored machines with an autonomy
level on every transition).

    start = "approach"
    [states.approach]
    command = { type = "ptwl", translation = [0.0, 0.0, 0.03], duration = 6.0, preset = "medium" }
    [[states.approach.transitions]]
    on = ["wrench_breach"]                      # the behavior's exits this transition takes
    when = [{ measure = "travel", op = ">=", value = 0.0285 }]   # guards on the report
    to = "relieve"                              # a state, or `completed` / `failed`
    autonomy = "high"                           # above the run's: the operator confirms

Everything is checked before anything runs (`MachineSpec.model_validate`): the start and every
target exist, every state is reachable, every exit a state's behavior can end with has a
transition that takes it unconditionally (a report can never match nothing), every loop passes
through a state with `max_visits` (a machine cannot run forever), every variable is defined
before it is read and of the right kind, every command is valid with its numbers filled in.
An error names the state and the field: `states.approach.transitions[1].to: ...`.
"""

import itertools
import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Annotated, Any, Literal, Self

from pydantic import Field, TypeAdapter, ValidationError, field_validator, model_validator

from robot_sim.params import DitherParams, GripperParams, PtwlParams, RweParams, StrictModel

# Names: a state, variable or setting (also what a graph or a CSV cell shows).
Name = Annotated[str, Field(pattern=r"^[a-z][a-z0-9_]{0,31}$")]
TERMINALS = ("completed", "failed")
START_POSE = "start"  # the pose variable every machine has: the port where it began

# FlexBE's levels, in order. A transition waits for the operator unless its level is below the
# run's autonomy (flexbe_core: `autonomy[outcome] < autonomy_level` is allowed): `off` runs
# itself unless autonomy is off; `full` always asks.
Autonomy = Literal["off", "low", "high", "full"]
AUTONOMY_LEVELS: tuple[Autonomy, ...] = ("off", "low", "high", "full")

# The exits each behavior can end with (a `monitor` adds `anomaly`). A STOP (`aborted`) or a
# fault ends the machine itself: no transition takes them.
Exit = Literal["goal_reached", "wrench_breach", "timeout", "completed", "anomaly"]
BEHAVIOR_EXITS: dict[str, tuple[Exit, ...]] = {
    "ptwl": ("goal_reached", "wrench_breach", "timeout"),
    "dither": ("goal_reached", "wrench_breach", "timeout"),
    "rwe": ("completed", "timeout"),
    "gripper": ("completed",),
}

MAX_STATES = 64
MAX_TRANSITIONS = 16
MAX_GUARDS = 8
MAX_VISITS = 200  # a tool exchange's 100 cycles visit its states 100 times
# Steps a machine written as data may run in all, whatever its visits allow: a request's machine
# cannot make the robot run (and record, and announce) more than this.
MAX_MACHINE_STEPS = 400
MAX_WHY = 300


def waits(level: Autonomy, autonomy: Autonomy) -> bool:
    """Whether a transition at `level` waits for the operator under a run's `autonomy`."""
    return AUTONOMY_LEVELS.index(level) >= AUTONOMY_LEVELS.index(autonomy)


class Ref(StrictModel):
    """A number read from a variable or setting: value * scale + offset."""

    var: Name
    scale: Annotated[float, Field(ge=-1e3, le=1e3)] = 1.0
    offset: Annotated[float, Field(ge=-1e3, le=1e3)] = 0.0


Measure = Literal["travel", "tilt", "twist", "peak_force", "peak_torque", "wrench", "visits", "detail", "var"]
MEASURE_DOC = (
    "travel [m] of the port along `axis` (x, y, z) of `frame` (`tool`: the `since` pose's own axes; "
    "`base`) since the pose variable `since`; tilt [rad]: how far the tool's z axis has swung since "
    "`since`; twist [rad]: the turn about the tool's z axis since `since`; peak_force [N], "
    "peak_torque [N m] over the behavior; wrench: the final wrench's `axis` (x y z rx ry rz, base "
    "axes) [N, N m]; visits: how often `state` has been entered; detail: the report's text "
    "(op `starts_with`); var: the variable or setting `var`"
)


class Reading(StrictModel):
    """What a guard compares or a variable keeps, read from a behavior's report."""

    measure: Measure = Field(description=MEASURE_DOC)
    axis: Literal["x", "y", "z", "rx", "ry", "rz"] = Field("z", description="travel's or wrench's axis")
    frame: Literal["tool", "base"] = Field("tool", description="travel's axes: the `since` pose's, or base")
    since: Name = Field(START_POSE, description="the pose variable travel, tilt and twist are measured from")
    state: Name | None = Field(None, description="visits: of this state")
    var: Name | None = Field(None, description="var: this variable or setting")

    @model_validator(mode="after")
    def _fits(self) -> Self:
        if self.measure == "travel" and self.axis not in ("x", "y", "z"):
            raise ValueError(f"travel's axis must be x, y or z, got {self.axis!r}")
        if self.measure == "visits" and self.state is None:
            raise ValueError("visits needs `state`")
        if self.measure == "var" and self.var is None:
            raise ValueError("var needs `var`")
        return self

    def reads(self) -> set[str]:
        """The variables it reads: the pose it is measured from, or the variable it is."""
        if self.measure in ("travel", "tilt", "twist"):
            return {self.since}
        return {self.var} if self.measure == "var" and self.var else set()

    @property
    def label(self) -> str:
        """How the record names the reading: `travel(tool z)`, `travel(base x since pressed)`,
        `wrench(rz)`, `visits(press)`; two guards that read different things never share one."""
        since = f" since {self.since}" if self.since != START_POSE else ""
        inner = {
            "travel": f"{self.frame} {self.axis}{since}",
            "tilt": since.strip(),
            "twist": since.strip(),
            "wrench": self.axis,
            "visits": self.state,
            "var": self.var,
        }.get(self.measure)
        return f"{self.measure}({inner})" if inner else self.measure


class Guard(Reading):
    op: Literal["<", "<=", ">", ">=", "starts_with"] = Field(description="how the reading compares")
    value: float | str | Ref = Field(description="a number, a Ref to a variable, or (detail) a text")

    @model_validator(mode="after")
    def _comparable(self) -> Self:
        text = self.measure == "detail"
        if text != (self.op == "starts_with") or text != isinstance(self.value, str):
            raise ValueError(
                "detail compares with op `starts_with` and a text; "
                "every other measure with < <= > >= and a number"
            )
        if isinstance(self.value, float) and not math.isfinite(self.value):
            raise ValueError("value must be finite")
        if isinstance(self.value, str) and len(self.value) > 100:
            raise ValueError("a detail's text is at most 100 characters")
        return self

    @property
    def text(self) -> str:
        value = self.value
        shown = (
            value.var if isinstance(value, Ref) else (repr(value) if isinstance(value, str) else f"{value:g}")
        )
        return f"{self.label} {self.op} {shown}"


KeepMeasure = Literal[
    "travel", "tilt", "twist", "peak_force", "peak_torque", "wrench", "visits", "var", "port"
]


class Keep(Reading):
    """A variable a state sets from its report: a number (any reading but the text `detail`) or
    `port`, the port's pose at the end (for `since` and the like)."""

    # Reading's measures, the text `detail` out, `port` in.
    measure: KeepMeasure = Field(  # type: ignore[assignment]
        description=f"port: the port's pose at the end; else (a number) {MEASURE_DOC}"
    )

    @property
    def is_pose(self) -> bool:
        return self.measure == "port"


class Transition(StrictModel):
    on: list[Exit] | None = Field(None, max_length=5, description="the exits it takes; omitted: any exit")
    when: list[Guard] = Field(default_factory=list, max_length=MAX_GUARDS, description="all must hold")
    to: Name = Field(description="the next state, or `completed` / `failed`")
    why: str = Field("", max_length=MAX_WHY, description="what taking it means (the record says it)")
    autonomy: Autonomy = Field(
        "off",
        description="FlexBE's level: waits for the operator unless below the run's "
        "(`off`: only when autonomy is off)",
    )

    def takes(self, exit_name: str) -> bool:
        return self.on is None or exit_name in self.on


Number = float | Ref


class State(StrictModel):
    command: dict[str, Any] = Field(
        description="a behavior command (ptwl, rwe, dither, gripper: the API's parameters); any number "
        "may be a Ref {var, scale, offset}"
    )
    why: str = Field("", max_length=MAX_WHY, description="what this step is for (the record says it)")
    transitions: list[Transition] = Field(min_length=1, max_length=MAX_TRANSITIONS)
    max_visits: int | Ref | None = Field(
        None, description=f"entered at most this many times (<= {MAX_VISITS}); then `exhausted`"
    )
    exhausted: Name = Field(
        "failed", description="where a transition into it goes once its visits are used up"
    )
    set: dict[Name, Keep] = Field(default_factory=dict, max_length=8, description="variables from its report")

    @field_validator("command")
    @classmethod
    def _behavior(cls, command: dict[str, Any]) -> dict[str, Any]:
        kind = command.get("type")
        if kind not in BEHAVIOR_EXITS:
            raise ValueError(f"type must be one of {', '.join(BEHAVIOR_EXITS)}, got {kind!r}")
        for key in ("sent_at", "max_age", "valid_until_sim_time"):
            if key in command:
                raise ValueError(f"{key}: a step starts when the machine decides, it cannot expire")
        _check_depth(command)
        return command

    @property
    def behavior(self) -> str:
        return str(self.command["type"])

    def exits(self) -> tuple[str, ...]:
        monitored = self.command.get("monitor") is not None
        return BEHAVIOR_EXITS[self.behavior] + (("anomaly",) if monitored else ())


class Setting(StrictModel):
    """A number an operator may override per run (`overrides`), within [min, max]."""

    value: float
    min: float
    max: float
    description: str = Field("", max_length=200)

    @model_validator(mode="after")
    def _inside(self) -> Self:
        if not all(math.isfinite(v) for v in (self.value, self.min, self.max)):
            raise ValueError("value, min and max must be finite")
        if not self.min <= self.value <= self.max:
            raise ValueError(
                f"value must be in [min, max] = [{self.min:g}, {self.max:g}], got {self.value:g}"
            )
        return self


MAX_COMMAND_DEPTH = 3  # a command's own values nest at most so deep: a list of Refs, a monitor's list


def _check_depth(command: dict[str, Any]) -> None:
    """Refuse nesting deeper than any command has (without recursing: a hostile body nests
    thousands deep)."""
    todo: list[tuple[Any, int]] = [(v, 1) for v in command.values()]
    while todo:
        value, depth = todo.pop()
        if isinstance(value, dict | list):
            if depth > MAX_COMMAND_DEPTH:
                raise ValueError(f"nested deeper than any command's values ({MAX_COMMAND_DEPTH} levels)")
            todo.extend((v, depth + 1) for v in (value.values() if isinstance(value, dict) else value))


_COMMANDS: dict[str, TypeAdapter[Any]] = {
    "ptwl": TypeAdapter(PtwlParams),
    "rwe": TypeAdapter(RweParams),
    "dither": TypeAdapter(DitherParams),
    "gripper": TypeAdapter(GripperParams),
}


def filled(command: Any, value_of: Callable[[str], float]) -> Any:
    """`command` with every Ref (a {"var": ...} table) replaced by its number from `value_of`."""
    if isinstance(command, dict):
        if "var" in command:
            ref = Ref.model_validate(command)
            return float(value_of(ref.var)) * ref.scale + ref.offset
        return {key: filled(value, value_of) for key, value in command.items()}
    if isinstance(command, list):
        return [filled(value, value_of) for value in command]
    return command


def command_params(command: dict[str, Any], value_of: Callable[[str], float]) -> Any:
    """The behavior's validated parameters, Refs filled in (pydantic.ValidationError if not)."""
    return _COMMANDS[command["type"]].validate_python(filled(command, value_of))


def refs_in(value: Any) -> Iterator[str]:
    """The variables a command (or any JSON-like value) reads."""
    if isinstance(value, dict):
        if "var" in value:
            yield str(value["var"])
            return
        for inner in value.values():
            yield from refs_in(inner)
    elif isinstance(value, list):
        for inner in value:
            yield from refs_in(inner)


class MachineSpec(StrictModel):
    """A whole machine: its states, where it starts, its settings."""

    name: Name = Field(description="the machine's name")
    task: Name | None = Field(None, description="the scene it is written for (its built-in's task)")
    summary: str = Field("", max_length=MAX_WHY)
    start: Name = Field(description="the first state")
    settings: dict[Name, Setting] = Field(default_factory=dict, max_length=16)
    states: dict[Name, State] = Field(min_length=1, max_length=MAX_STATES)

    @model_validator(mode="after")
    def _whole(self) -> Self:
        problems = list(self._problems())
        if problems:
            raise ValueError("; ".join(problems))
        return self

    # ------------------------------------------------------------------ the checks
    def _problems(self) -> Iterator[str]:
        names = set(self.states)
        if self.start not in names:
            yield f"start: no state {self.start!r} (states: {', '.join(sorted(names))})"
            return
        for name in sorted(names & (set(TERMINALS) | {START_POSE} | set(self.settings))):
            yield f"states.{name}: the name is taken (completed, failed, start and the settings' names)"
        kinds = self._variable_kinds()
        for where, problem in kinds.problems:
            yield f"{where}: {problem}"
        for name, state in self.states.items():
            yield from self._state_problems(name, state, names, kinds)
        yield from self._read_before_set(kinds)
        yield from self.command_problems(self.defaults(), extremes=True)
        for name in sorted(names - self._reachable()):
            yield f"states.{name}: unreachable from {self.start!r}"
        loop = self._unbounded_loop()
        if loop:
            yield (
                f"states.{loop[0]}: the loop {' -> '.join(loop)} has no state with max_visits: "
                "give one of them max_visits so the machine cannot run forever"
            )

    def _variable_kinds(self) -> "_Kinds":
        """Every variable's kind (pose or number), and the names no variable may take: a
        setting's (a run's overrides would not be what a state sets), `start`, or one name for
        both a pose and a number."""
        kinds = _Kinds({START_POSE: "pose", **{n: "number" for n in self.settings}})
        for name, state in self.states.items():
            for var, keep in state.set.items():
                kind = "pose" if keep.is_pose else "number"
                where = f"states.{name}.set.{var}"
                if var == START_POSE or var in self.settings:
                    kinds.problems.append(
                        (
                            where,
                            f"{var!r} is taken ({'the start pose' if var == START_POSE else 'a setting'})",
                        )
                    )
                elif kinds.of.setdefault(var, kind) != kind:
                    kinds.problems.append(
                        (where, f"{var!r} is a {kinds.of[var]} elsewhere; a name keeps one kind")
                    )
        return kinds

    def _state_problems(self, name: str, state: State, names: set[str], kinds: "_Kinds") -> Iterator[str]:
        here = f"states.{name}"
        for i, t in enumerate(state.transitions):
            if t.to not in names and t.to not in TERMINALS:
                yield f"{here}.transitions[{i}].to: no state {t.to!r} (nor completed, failed)"
            for j, guard in enumerate(t.when):
                yield from self._reading_problems(f"{here}.transitions[{i}].when[{j}]", guard, names, kinds)
                if isinstance(guard.value, Ref) and kinds.of.get(guard.value.var) != "number":
                    yield (
                        f"{here}.transitions[{i}].when[{j}].value: "
                        f"no number variable or setting {guard.value.var!r}"
                    )
            for taken in t.on or ():
                if taken not in state.exits():
                    ends = ", ".join(state.exits())
                    yield f"{here}.transitions[{i}].on: a {state.behavior} never ends {taken!r} ({ends})"
        for exit_name in state.exits():
            if not any(t.takes(exit_name) and not t.when for t in state.transitions):
                yield (
                    f"{here}.transitions: nothing takes exit {exit_name!r} whatever the report says "
                    f"(add a transition with on = [{exit_name!r}] and no `when`, or one with no `on`)"
                )
        if state.exhausted not in names and state.exhausted not in TERMINALS:
            yield f"{here}.exhausted: no state {state.exhausted!r}"
        for var, keep in state.set.items():
            if not keep.is_pose:
                yield from self._reading_problems(f"{here}.set.{var}", keep, names, kinds)
        for var in refs_in(state.command):
            if kinds.of.get(var) != "number":
                yield f"{here}.command: no number variable or setting {var!r}"
        if isinstance(state.max_visits, Ref) and state.max_visits.var not in self.settings:
            yield f"{here}.max_visits: a Ref here must name a setting, got {state.max_visits.var!r}"
        for visits in self._visit_bounds(state):
            if not 0 <= visits <= MAX_VISITS:
                yield f"{here}.max_visits: must be in [0, {MAX_VISITS}], got {visits:g}"

    @staticmethod
    def _reading_problems(where: str, reading: Reading, names: set[str], kinds: "_Kinds") -> Iterator[str]:
        if reading.measure in ("travel", "tilt", "twist") and kinds.of.get(reading.since) != "pose":
            yield f"{where}.since: no pose variable {reading.since!r} (start, or a `set` with measure port)"
        if reading.measure == "visits" and reading.state not in names:
            yield f"{where}.state: no state {reading.state!r}"
        if reading.measure == "var" and kinds.of.get(reading.var or "") != "number":
            yield f"{where}.var: no number variable or setting {reading.var!r}"

    def _read_before_set(self, kinds: "_Kinds") -> Iterator[str]:
        """A variable read where some way there has not set it: entering a state fills its
        command (what has been set before it); its guards and its own `set` read after its
        own `set`. Known on entry: what every way into the state has set (the settings and
        `start` from the start)."""
        given = {START_POSE, *self.settings}
        everything = set(kinds.of)
        known = {name: set(everything) for name in self.states}  # shrinks to the fixpoint
        known[self.start] = set(given)
        changed = True
        while changed:
            changed = False
            for name, state in self.states.items():
                out = known[name] | set(state.set)
                for nxt in self.successors(name):
                    narrowed = known[nxt] & out if nxt != self.start else known[nxt] & given
                    if narrowed != known[nxt]:
                        known[nxt], changed = narrowed, True
        for name, state in self.states.items():
            here = f"states.{name}"
            for var in sorted(set(refs_in(state.command)) & everything - known[name]):
                yield f"{here}.command: reads {var!r} before every way here sets it"
            after = set(known[name])
            for var, keep in state.set.items():  # in order: each may read those before it
                for read in sorted(keep.reads() & everything - after):
                    yield f"{here}.set.{var}: reads {read!r} before every way here sets it"
                after.add(var)
            for i, t in enumerate(state.transitions):
                for j, guard in enumerate(t.when):
                    guarded = guard.reads() | ({guard.value.var} if isinstance(guard.value, Ref) else set())
                    for var in sorted(guarded & everything - after):
                        yield f"{here}.transitions[{i}].when[{j}]: reads {var!r} before every way sets it"

    def command_problems(self, settings: dict[str, float], extremes: bool = False) -> Iterator[str]:
        """Each command filled with `settings` (and, with `extremes`, at each combination of the
        min and max of those it reads: what any run's overrides can make of it). A field that
        reads a variable a state sets is checked as it is filled in, at run time (a bad value
        then ends the machine `failed`, naming the state and field); its other fields here."""
        for name, state in self.states.items():
            read = set(refs_in(state.command))
            from_reports = read - set(self.settings)
            late = {key for key, value in state.command.items() if set(refs_in(value)) & from_reports}
            corners: list[dict[str, float]] = [{}]
            if extremes:
                ends = [
                    (self.settings[v].min, self.settings[v].max) for v in sorted(read & set(self.settings))
                ]
                names = sorted(read & set(self.settings))
                corners += [
                    dict(zip(names, c, strict=True)) for c in itertools.islice(itertools.product(*ends), 16)
                ]
            for corner in corners:
                values = {**settings, **corner, **dict.fromkeys(from_reports, 0.0)}
                said = [
                    f"states.{name}.command.{at}: {message}" + _at_settings(corner)
                    for at, message in _command_errors(state, values)
                    if at.split(".")[0] not in late and not (from_reports and at == "command")
                ]
                yield from said
                if said:
                    break

    def _visit_bounds(self, state: State) -> list[float]:
        """max_visits at the settings' least and greatest (a Ref to a setting may be overridden)."""
        bound = state.max_visits
        if bound is None:
            return []
        if isinstance(bound, int):
            return [bound]
        setting = self.settings.get(bound.var)
        if setting is None:
            return []
        return [setting.min * bound.scale + bound.offset, setting.max * bound.scale + bound.offset]

    def successors(self, name: str) -> set[str]:
        """Where a transition out of `name` can lead: its target, or (a bounded target's visits
        used up) that target's `exhausted`."""
        targets: set[str] = set()
        for t in self.states[name].transitions:
            target = self.states.get(t.to)
            targets.add(t.to)
            if target is not None and target.max_visits is not None:
                targets.add(target.exhausted)
        return targets & set(self.states)

    def _reachable(self) -> set[str]:
        seen, todo = {self.start}, [self.start]
        while todo:
            for nxt in self.successors(todo.pop()):
                if nxt not in seen:
                    seen.add(nxt)
                    todo.append(nxt)
        return seen

    def _unbounded_loop(self) -> list[str]:
        """A cycle through states without max_visits (as a path), or [] when every loop is bounded."""
        free = {n for n, s in self.states.items() if s.max_visits is None}
        colour: dict[str, int] = {}
        path: list[str] = []

        def visit(node: str) -> list[str]:
            colour[node] = 1
            path.append(node)
            for nxt in sorted(self.successors(node) & free):
                if colour.get(nxt) == 1:
                    return [*path[path.index(nxt) :], nxt]
                if nxt not in colour and (found := visit(nxt)):
                    return found
            colour[node] = 2
            path.pop()
            return []

        for node in sorted(free):
            if node not in colour and (found := visit(node)):
                return found
        return []

    # ------------------------------------------------------------------ for the engine
    def defaults(self) -> dict[str, float]:
        return {name: setting.value for name, setting in self.settings.items()}

    def visits_allowed(self, name: str, settings: dict[str, float]) -> int | None:
        bound = self.states[name].max_visits
        if bound is None or isinstance(bound, int):
            return bound
        return round(settings[bound.var] * bound.scale + bound.offset)

    def edges(self) -> list[tuple[str, str, str, Autonomy]]:
        """(from, to, label, level) for every transition, and each bounded state's `exhausted`."""
        found: list[tuple[str, str, str, Autonomy]] = []
        for name, state in self.states.items():
            for t in state.transitions:
                label = ",".join(t.on) if t.on else "any"
                if t.when:
                    label += " if " + " and ".join(g.text for g in t.when)
                found.append((name, t.to, label, t.autonomy))
            if state.max_visits is not None:
                found.append((name, state.exhausted, "visits used up", "off"))
        return found


def command_refusals(err: ValidationError, behavior: str) -> list[tuple[str, str]]:
    """(field, message) for each error of a command of `behavior` (its tag left out of the field)."""
    return [
        (
            ".".join(str(p) for p in e["loc"] if p != behavior) or "command",
            e["msg"].removeprefix("Value error, "),
        )
        for e in err.errors()
    ]


def _command_errors(state: "State", values: dict[str, float]) -> list[tuple[str, str]]:
    """(field, message) for each error of the state's command filled with `values`."""
    try:
        command_params(state.command, values.__getitem__)
    except ValidationError as err:
        return command_refusals(err, state.behavior)
    return []


def _at_settings(corner: dict[str, float]) -> str:
    return " (with " + ", ".join(f"{k} = {v:g}" for k, v in corner.items()) + ")" if corner else ""


@dataclass
class _Kinds:
    """Variables by kind ("pose" or "number"), and where a name was misused."""

    of: dict[str, str]
    problems: list[tuple[str, str]] = field(default_factory=list)

"""Machines written as data (robot_sim/machines): the built-in files give the steps their Python
policies gave, every validation error names the state and field, and the README's example is a
machine that runs."""

import json
import re
import tomllib
from pathlib import Path
from typing import Any

import pytest
from pydantic import ValidationError

from robot_sim.behaviors import BehaviorReport, ExitCondition, Pose
from robot_sim.errors import ConfigError
from robot_sim.machines.command import DecisionRequest, StateMachineParams
from robot_sim.machines.engine import _refusal, policy_class
from robot_sim.machines.library import builtin_machines, read_machine
from robot_sim.machines.spec import AUTONOMY_LEVELS, MAX_MACHINE_STEPS, MAX_VISITS, MachineSpec, waits
from robot_sim.policies import POLICIES, Finish, Step, run_onboard

ROOT = Path(__file__).resolve().parent.parent
STEPS = json.loads((Path(__file__).parent / "data" / "python_policy_steps.json").read_text())
HOME = Pose((0.4, 0.0, 0.3), (0.0, 1.0, 0.0, 0.0))  # tool z pointing down


def base() -> dict[str, Any]:
    """A small valid machine: press down, relieve, done; a retry loop bounded by max_visits."""
    return {
        "name": "press",
        "start": "press",
        "settings": {"depth": {"value": 0.01, "min": 0.001, "max": 0.05}},
        "states": {
            "press": {
                "command": {"type": "ptwl", "translation": [0.0, 0.0, {"var": "depth"}], "duration": 1.0},
                "set": {"pressed_at": {"measure": "port"}},
                "max_visits": 3,
                "transitions": [
                    {"on": ["wrench_breach"], "to": "relieve", "autonomy": "high"},
                    {"when": [{"measure": "travel", "op": "<", "value": 0.005}], "to": "press"},
                    {"to": "failed"},
                ],
            },
            "relieve": {"command": {"type": "rwe"}, "transitions": [{"to": "completed"}]},
        },
    }


def refusal(machine: dict[str, Any]) -> str:
    with pytest.raises(ValidationError) as caught:
        MachineSpec.model_validate(machine)
    return str(caught.value)


@pytest.mark.parametrize("key", sorted(STEPS))
def test_a_built_in_file_gives_the_steps_its_python_policy_gave_on_the_same_seed(key: str) -> None:
    """tests/data/python_policy_steps.json: each converted task's Python policy run on seed 7,
    and on seed 3 with max_recoveries 0, before it was replaced (same parameters, same exits at
    the same sim times: the physics saw the same commands)."""
    task, seed, overrides = key.split(":", 2)
    want = STEPS[key]
    # The tool machines' Python settings had a max_recoveries they never read: their files have
    # no settings, and refuse it (test_a_setting_nobody_reads_is_refused).
    settings = builtin_machines()[task].settings
    kept = {name: value for name, value in json.loads(overrides).items() if name in settings}
    run = run_onboard(task, int(seed), overrides=kept)
    got = [
        {"params": s.params.model_dump(), "exit": s.report.exit.value, "ended_at": s.report.ended_at}
        for s in run.steps
    ]
    assert differences(got, want["steps"]) == []
    assert (run.end, run.success) == (want["end"], want["success"])


# The steps were recorded on one machine; MuJoCo's floating point differs in its last digits from
# one CPU to another (an AMD EPYC read a door's angle 3e-7 rad off the recording, so a parameter
# measured from it). Same commands: each number within 1e-5 of it, each end within 2 ticks; texts,
# exits and the steps' order exactly.
REL_TOLERANCE, ENDED_AT_TOLERANCE_S = 1e-5, 0.002


def differences(got: Any, want: Any, where: str = "") -> list[str]:
    """Where `got` is not the recorded `want`, within the tolerances above."""
    if isinstance(want, dict) and isinstance(got, dict) and got.keys() == want.keys():
        return [d for key in want for d in differences(got[key], want[key], f"{where}.{key}")]
    if isinstance(want, list) and isinstance(got, list) and len(got) == len(want):
        return [
            d
            for i, (g, w) in enumerate(zip(got, want, strict=True))
            for d in differences(g, w, f"{where}[{i}]")
        ]
    if type(want) is float and type(got) is float:
        relative = max(REL_TOLERANCE * abs(want), 1e-12)
        tolerance = ENDED_AT_TOLERANCE_S if where.endswith(".ended_at") else relative
        return [] if abs(got - want) <= tolerance else [f"{where}: {got!r} != {want!r}"]
    return [] if got == want else [f"{where}: {got!r} != {want!r}"]


def test_seven_tasks_are_files_and_three_are_python() -> None:
    assert sorted(builtin_machines()) == [
        "berthing",
        "door",
        "plug",
        "quick_connect",
        "socket_wrench",
        "tool_retrieval",
        "tool_stowage",
    ]
    python = sorted(set(POLICIES) - set(builtin_machines()))
    assert python == ["lid", "sleeve_on_peg", "tool_exchange"]


def test_the_readme_example_is_a_valid_machine_that_completes_on_its_scene() -> None:
    text = (ROOT / "README.md").read_text()
    block = re.search(r"```toml\n(# machine: .*?)```", text, re.S)
    assert block is not None, "the README's machine example (a ```toml block starting '# machine:')"
    spec = MachineSpec.model_validate(tomllib.loads(block.group(1)))
    assert spec.task is not None
    run = run_onboard(spec.task, 0, sim=None, machine=spec)
    assert run.end == "completed" and run.success, run.why


def test_a_machine_file_is_read_and_its_errors_name_the_file_state_and_field(tmp_path: Path) -> None:
    good = tmp_path / "plug.toml"
    good.write_text((ROOT / "robot_sim/machines/builtin/plug.toml").read_text())
    assert read_machine(good) == builtin_machines()["plug"]
    bad = tmp_path / "bad.toml"
    bad.write_text(good.read_text().replace('to = "slide_minus"', 'to = "slid_minus"'))
    with pytest.raises(
        ConfigError, match=r"bad\.toml: .*states\.slide_plus\.transitions\[3\]\.to: no state 'slid_minus'"
    ):
        read_machine(bad)
    bad.write_text("name = [")
    with pytest.raises(ConfigError, match="not TOML"):
        read_machine(bad)


# ------------------------------------------------------------------ validation, one error each
def test_the_base_machine_is_valid() -> None:
    spec = MachineSpec.model_validate(base())
    assert spec.start == "press" and set(spec.states) == {"press", "relieve"}


def test_an_unknown_start_is_refused() -> None:
    machine = base() | {"start": "presss"}
    assert "start: no state 'presss' (states: press, relieve)" in refusal(machine)


def test_a_transition_to_an_unknown_state_is_refused() -> None:
    machine = base()
    machine["states"]["relieve"]["transitions"] = [{"to": "complete"}]
    assert "states.relieve.transitions[0].to: no state 'complete' (nor completed, failed)" in refusal(machine)


def test_an_unreachable_state_is_refused() -> None:
    machine = base()
    machine["states"]["orphan"] = {"command": {"type": "rwe"}, "transitions": [{"to": "completed"}]}
    assert "states.orphan: unreachable from 'press'" in refusal(machine)


def test_an_exit_with_no_transition_is_refused() -> None:
    machine = base()
    machine["states"]["press"]["transitions"] = [
        {"on": ["wrench_breach"], "to": "relieve"},
        {"on": ["goal_reached"], "to": "completed"},
        {"on": ["timeout"], "when": [{"measure": "peak_force", "op": ">", "value": 5.0}], "to": "failed"},
    ]
    said = refusal(machine)
    assert "states.press.transitions: nothing takes exit 'timeout' whatever the report says" in said
    assert "'goal_reached'" not in said.split("nothing takes exit")[1]  # only the one missing


def test_an_exit_the_behavior_never_ends_with_is_refused() -> None:
    machine = base()
    machine["states"]["relieve"]["transitions"] = [
        {"on": ["wrench_breach"], "to": "completed"},
        {"to": "failed"},
    ]
    assert "states.relieve.transitions[0].on: a rwe never ends 'wrench_breach'" in refusal(machine)


def test_a_loop_without_a_bound_is_refused_and_max_visits_bounds_it() -> None:
    machine = base()
    del machine["states"]["press"]["max_visits"]
    assert "states.press: the loop press -> press has no state with max_visits" in refusal(machine)
    # A loop through two states, bounded by either.
    machine = base()
    del machine["states"]["press"]["max_visits"]
    machine["states"]["press"]["transitions"][1]["to"] = "failed"  # no press -> press
    machine["states"]["relieve"]["transitions"] = [{"to": "press"}]
    assert "the loop press -> relieve -> press has no state with max_visits" in refusal(machine)
    machine["states"]["relieve"]["max_visits"] = 2
    MachineSpec.model_validate(machine)
    # Used up, a transition goes to `exhausted`: leading back into the loop is a loop too.
    machine["states"]["relieve"]["exhausted"] = "press"
    assert "no state with max_visits" in refusal(machine)


def test_a_command_out_of_range_is_refused_naming_the_state_and_field() -> None:
    machine = base()
    machine["states"]["relieve"]["command"] = {"type": "rwe", "duration": 700.0}
    assert "states.relieve.command.duration: must be in (0, 600] s, got 700" in refusal(machine)
    machine = base()
    machine["settings"]["depth"] = {"value": 2.0, "min": 0.0, "max": 3.0}  # the PTWL's translation
    assert "states.press.command.translation: magnitude must be <= 1 m, got 2" in refusal(machine)
    machine = base()
    machine["states"]["relieve"]["command"] = {"type": "jump"}
    assert "states.relieve.command" in refusal(
        machine
    ) and "type must be one of ptwl, dither, rwe, gripper" in refusal(machine)


def test_an_undefined_or_mistyped_variable_is_refused() -> None:
    machine = base()
    machine["states"]["press"]["command"]["translation"][2] = {"var": "dept"}
    assert "states.press.command: no number variable or setting 'dept'" in refusal(machine)
    machine = base()
    machine["states"]["relieve"]["transitions"] = [
        {"when": [{"measure": "travel", "since": "press", "op": ">", "value": 0.0}], "to": "completed"},
        {"to": "failed"},
    ]
    assert "states.relieve.transitions[0].when[0].since: no pose variable 'press'" in refusal(machine)
    machine = base()
    machine["states"]["relieve"]["command"] = {"type": "rwe", "duration": {"var": "pressed_at"}}  # a pose
    assert "no number variable or setting 'pressed_at'" in refusal(machine)


def test_a_guard_that_compares_the_wrong_kind_is_refused() -> None:
    machine = base()
    machine["states"]["relieve"]["transitions"] = [
        {"when": [{"measure": "detail", "op": ">", "value": 1.0}], "to": "completed"},
        {"to": "failed"},
    ]
    assert "detail compares with op `starts_with` and a text" in refusal(machine)


def test_a_guard_reading_a_pose_as_a_number_is_refused() -> None:
    machine = base()
    machine["states"]["relieve"]["transitions"] = [
        {"when": [{"measure": "var", "var": "pressed_at", "op": ">", "value": 1.0}], "to": "completed"},
        {"to": "failed"},
    ]
    assert "transitions[0].when[0].var: no number variable or setting 'pressed_at'" in refusal(machine)


def test_a_details_text_is_at_most_100_characters() -> None:
    machine = base()
    guard = {"measure": "detail", "op": "starts_with", "value": "x" * 100}
    machine["states"]["relieve"]["transitions"] = [{"when": [guard], "to": "completed"}, {"to": "failed"}]
    MachineSpec.model_validate(machine)
    guard["value"] = "x" * 101
    assert "a detail's text is at most 100 characters" in refusal(machine)


def test_a_setting_outside_its_own_range_and_bad_overrides_are_refused() -> None:
    machine = base()
    machine["settings"]["depth"] = {"value": 0.1, "min": 0.001, "max": 0.05}
    assert "settings.depth" in refusal(
        machine
    ) and "value must be in [min, max] = [0.001, 0.05], got 0.1" in refusal(machine)
    spec = MachineSpec.model_validate(base())
    with pytest.raises(
        ValidationError, match=r"overrides for press: depth: Input should be less than or equal to 0.05"
    ):
        StateMachineParams(machine=spec, overrides={"depth": 0.2})
    with pytest.raises(ValidationError, match=r"overrides for press: dpth: Extra inputs are not permitted"):
        StateMachineParams(machine=spec, overrides={"dpth": 0.02})
    with pytest.raises(ValidationError, match=r"give either task .* or machine"):
        StateMachineParams(task="plug", machine=spec)


def test_a_setting_nobody_reads_is_refused() -> None:
    with pytest.raises(ValidationError, match=r"overrides for tool_retrieval: max_recoveries: Extra inputs"):
        StateMachineParams(task="tool_retrieval", overrides={"max_recoveries": 0})


def test_a_python_machine_runs_at_full_autonomy_only() -> None:
    with pytest.raises(ValidationError, match="autonomy: the lid machine is Python"):
        StateMachineParams(task="lid", autonomy="high")
    assert StateMachineParams(task="lid").autonomy == "full"
    assert StateMachineParams(task="plug", autonomy="off").spec() is builtin_machines()["plug"]


def test_a_decision_names_what_its_choice_needs() -> None:
    with pytest.raises(ValidationError, match="outcome: give it with choice `outcome`"):
        DecisionRequest(decision=1, choice="outcome")
    with pytest.raises(ValidationError, match="state: give it with choice `force`"):
        DecisionRequest(decision=1, choice="confirm", state="press")
    with pytest.raises(ValidationError):
        DecisionRequest(decision=0, choice="confirm")


# ------------------------------------------------------------------------------- the engine
def report(exit_name: ExitCondition, port: Pose, detail: str = "") -> BehaviorReport:
    return BehaviorReport(
        "ptwl", exit_name, 0.0, 1.0, 12.0, 0.1, (0.0, 0.0, 12.0, 0.0, 0.0, 0.0), port, detail
    )


def down(by_m: float) -> Pose:
    (x, y, z), q = HOME.position, HOME.quaternion
    return Pose((x, y, z - by_m), q)  # the tool's z points down: down is along it


def test_the_engine_takes_the_first_transition_whose_exit_and_guards_match() -> None:
    policy = policy_class(MachineSpec.model_validate(base()))({"depth": 0.02})
    first = policy.first(HOME)
    assert first.state == "press" and first.params.translation == [0.0, 0.0, 0.02]  # type: ignore[union-attr]
    again = policy.next(report(ExitCondition.TIMEOUT, down(0.004)))  # 4 mm < 5 mm: press again
    assert isinstance(again, Step) and again.state == "press" and "travel(tool z) 0.004" in again.why
    failed = policy.next(report(ExitCondition.TIMEOUT, down(0.006)))
    assert isinstance(failed, Finish) and not failed.completed
    assert failed.why == "press ended timeout (travel(tool z) 0.006): failed"


def test_visits_used_up_lead_to_exhausted() -> None:
    policy = policy_class(MachineSpec.model_validate(base()))()
    policy.first(HOME)
    for _ in range(2):  # visits 2 and 3
        assert isinstance(policy.next(report(ExitCondition.TIMEOUT, HOME)), Step)
    assert policy.visits["press"] == 3
    ended = policy.next(report(ExitCondition.TIMEOUT, HOME))
    assert isinstance(ended, Finish) and not ended.completed
    assert "press used its 3 visits" in ended.why


def test_propose_changes_nothing_and_commit_takes_it() -> None:
    policy = policy_class(MachineSpec.model_validate(base()))()
    policy.first(HOME)
    breach = report(ExitCondition.WRENCH_BREACH, down(0.003))
    proposal = policy.propose(breach)
    assert (proposal.target, proposal.level, proposal.transition) == ("relieve", "high", 0)
    assert policy.state == "press" and policy.visits["relieve"] == 0 and "pressed_at" not in policy.poses
    other = policy.propose(breach, "timeout")  # an operator's other outcome: 3 mm < 5 mm
    assert (other.target, other.transition) == ("press", 1)
    step = policy.commit(proposal, breach)
    assert isinstance(step, Step) and step.state == "relieve" and policy.poses["pressed_at"] == down(0.003)
    forced = policy.force("completed", breach)
    assert policy.commit(forced, breach) == Finish(
        True, "relieve ended wrench_breach, forced by the operator: completed"
    )
    with pytest.raises(KeyError):
        policy.force("nowhere", breach)


def test_flexbe_levels_a_transition_waits_unless_below_the_runs_autonomy() -> None:
    table = {(lv, run): waits(lv, run) for lv in AUTONOMY_LEVELS for run in AUTONOMY_LEVELS}
    assert table[("off", "off")] and not table[("off", "low")]  # `off`: only when autonomy is off
    assert table[("high", "low")] and table[("high", "high")] and not table[("high", "full")]
    assert table[("full", "full")]  # `full` always asks
    assert sum(table.values()) == 10  # level index >= autonomy index: 4 + 3 + 2 + 1


# ----------------------------------------------------- what an outside review tried (issue 31)
def test_a_variable_read_before_every_way_there_sets_it_is_refused() -> None:
    machine = base()
    machine["states"]["press"]["command"]["duration"] = {"var": "later", "offset": 1.0}
    machine["states"]["relieve"]["set"] = {"later": {"measure": "peak_force"}}
    assert "states.press.command: reads 'later' before every way here sets it" in refusal(machine)
    # Set on one way in but not the other: still refused where the ways meet.
    machine = base()
    machine["states"]["relieve"]["transitions"] = [
        {"when": [{"measure": "travel", "since": "pressed_at", "op": ">", "value": 0.0}], "to": "completed"},
        {"to": "failed"},
    ]
    MachineSpec.model_validate(machine)  # relieve is entered only from press, which sets it
    machine["start"] = "relieve"
    said = refusal(machine)
    assert "states.relieve.transitions[0].when[0]: reads 'pressed_at' before every way sets it" in said


def test_names_a_variable_may_not_take_are_refused() -> None:
    machine = base()
    machine["states"]["relieve"]["set"] = {"depth": {"measure": "peak_force"}}  # a setting's
    assert "states.relieve.set.depth: 'depth' is taken (a setting)" in refusal(machine)
    machine["states"]["relieve"]["set"] = {"start": {"measure": "port"}}
    assert "states.relieve.set.start: 'start' is taken (the start pose)" in refusal(machine)
    machine["states"]["relieve"]["set"] = {"pressed_at": {"measure": "peak_force"}}  # a pose in press
    assert "'pressed_at' is a pose elsewhere; a name keeps one kind" in refusal(machine)
    machine["states"]["relieve"]["set"] = {"said": {"measure": "detail"}}  # text is not a number
    with pytest.raises(ValidationError, match=r"states\.relieve\.set\.said\.measure"):
        MachineSpec.model_validate(machine)
    machine["states"]["relieve"]["set"] = {"count": {"measure": "visits"}}  # no state named
    with pytest.raises(ValidationError, match=r"states\.relieve\.set\.count\n.*visits needs `state`"):
        MachineSpec.model_validate(machine)


def test_a_command_out_of_range_at_a_settings_extreme_is_refused() -> None:
    machine = base()
    machine["settings"]["force_n"] = {"value": 20.0, "min": 1.0, "max": 1e308}
    machine["states"]["press"]["command"]["force_threshold"] = {"var": "force_n"}
    said = refusal(machine)
    assert (
        "states.press.command.force_threshold: must be in (0, 500] N, got 1e+308 (with depth = 0.001" in said
    )
    # Within the file's range, an override the command would refuse is refused when sent.
    machine["settings"]["force_n"]["max"] = 500.0
    spec = MachineSpec.model_validate(machine)
    assert StateMachineParams(machine=spec, overrides={"force_n": 400.0}).overrides == {"force_n": 400.0}


def test_deep_nesting_is_refused_without_recursing() -> None:
    machine = base()
    deep: Any = 0.01
    for _ in range(5000):
        deep = [deep]
    machine["states"]["relieve"]["command"] = {"type": "rwe", "duration": deep}
    assert "nested deeper than any command's values (3 levels)" in refusal(machine)


def test_a_value_filled_in_out_of_range_ends_the_machine_failed_naming_the_field() -> None:
    machine = base()
    machine["states"]["press"]["set"]["n"] = {"measure": "visits", "state": "press"}
    machine["states"]["relieve"]["command"] = {
        "type": "rwe",
        "duration": {"var": "n", "scale": -5.0, "offset": 1.0},
    }
    spec = MachineSpec.model_validate(machine)  # the duration reads a report's variable: checked as filled in
    policy = policy_class(spec)()
    policy.first(HOME)
    ended = policy.next(report(ExitCondition.WRENCH_BREACH, down(0.003)))
    assert isinstance(ended, Finish) and not ended.completed
    assert ended.why.endswith(
        "relieve's command cannot be filled in: duration: must be in (0, 600] s, got -4"
    )
    assert policy.state == "press" and policy.visits["relieve"] == 0  # never entered


def test_guards_measured_from_different_poses_read_each_their_own() -> None:
    machine = base()
    machine["states"]["press"]["transitions"] = [
        {
            "on": ["wrench_breach"],
            "when": [
                {"measure": "travel", "op": ">=", "value": 0.05},  # since start: 0.105
                {"measure": "travel", "since": "mid", "op": "<", "value": 0.01},  # since mid: 0.005
            ],
            "to": "relieve",
        },
        {"to": "failed"},
    ]
    machine["states"]["press"]["set"] = {}
    machine["states"]["first"] = {
        "command": {"type": "rwe"},
        "set": {"mid": {"measure": "port"}},
        "transitions": [{"to": "press"}],
    }
    machine["start"] = "first"
    policy = policy_class(MachineSpec.model_validate(machine))()
    policy.first(HOME)
    assert isinstance(policy.next(report(ExitCondition.COMPLETED, down(0.1))), Step)  # mid: 100 mm down
    decided = policy.next(report(ExitCondition.WRENCH_BREACH, down(0.105)))
    assert isinstance(decided, Step) and decided.state == "relieve", decided
    assert "travel(tool z) 0.105, travel(tool z since mid) 0.005" in decided.why


def test_a_machine_runs_at_most_its_step_bound() -> None:
    states = {
        f"s{i}": {"command": {"type": "rwe"}, "max_visits": 200, "transitions": [{"to": f"s{(i + 1) % 64}"}]}
        for i in range(64)
    }
    spec = MachineSpec.model_validate({"name": "ring", "start": "s0", "states": states})
    assert policy_class(spec)().max_steps() == MAX_MACHINE_STEPS == 400


def test_a_variable_set_on_one_way_in_but_not_the_other_is_refused() -> None:
    machine = base()
    machine["states"]["press"]["transitions"] = [
        {"on": ["wrench_breach"], "to": "relieve"},
        {"on": ["timeout"], "to": "side"},  # this way into relieve does not set `pressed_at`
        {"to": "failed"},
    ]
    machine["states"]["press"]["set"] = {}
    machine["states"]["side"] = {
        "command": {"type": "rwe"},
        "transitions": [{"to": "relieve"}],
    }
    machine["states"]["press"]["transitions"][0]["to"] = "marked"
    machine["states"]["marked"] = {
        "command": {"type": "rwe"},
        "set": {"pressed_at": {"measure": "port"}},
        "transitions": [{"to": "relieve"}],
    }
    machine["states"]["relieve"]["transitions"] = [
        {"when": [{"measure": "travel", "since": "pressed_at", "op": ">", "value": 0.0}], "to": "completed"},
        {"to": "failed"},
    ]
    said = refusal(machine)
    assert "states.relieve.transitions[0].when[0]: reads 'pressed_at' before every way sets it" in said
    machine["states"]["side"]["set"] = {"pressed_at": {"measure": "port"}}  # both ways set it now
    MachineSpec.model_validate(machine)


def test_max_visits_is_bounded() -> None:
    machine = base()
    machine["states"]["press"]["max_visits"] = MAX_VISITS + 1
    assert f"states.press.max_visits: must be in [0, {MAX_VISITS}], got {MAX_VISITS + 1}" in refusal(machine)
    machine["states"]["press"]["max_visits"] = MAX_VISITS
    MachineSpec.model_validate(machine)


@pytest.mark.parametrize(("op", "holds"), [("<", False), ("<=", True), (">", False), (">=", True)])
def test_a_guard_at_its_bound_holds_as_its_operator_says(op: str, holds: bool) -> None:
    machine = base()
    machine["states"]["press"]["transitions"] = [
        {"when": [{"measure": "peak_force", "op": op, "value": 12.0}], "to": "relieve"},  # the report's 12 N
        {"to": "failed"},
    ]
    policy = policy_class(MachineSpec.model_validate(machine))()
    policy.first(HOME)
    decided = policy.next(report(ExitCondition.TIMEOUT, HOME))
    assert isinstance(decided, Step) == holds, decided


def test_overrides_that_make_a_command_invalid_are_refused_when_sent() -> None:
    """A command reading more settings than the file's check tries every corner of (16): the
    run's own overrides are checked when sent."""
    machine = base()
    machine["settings"] = {
        "a_far": {"value": 0.5, "min": 0.0, "max": 2.0},  # sorted first: its max is past the 16 corners tried
        **{f"r{i}": {"value": 0.0, "min": 0.0, "max": 0.01} for i in range(4)},
    }
    machine["states"]["press"]["command"] = {
        "type": "ptwl",
        "translation": [{"var": "a_far"}, 0.0, 0.0],
        "rotation": [{"var": "r0"}, {"var": "r1"}, {"var": "r2"}],
        "duration": 1.0,
        "position_tolerance": {"var": "r3", "offset": 0.001},
    }
    spec = MachineSpec.model_validate(machine)
    assert StateMachineParams(machine=spec, overrides={"a_far": 0.9}).overrides == {"a_far": 0.9}
    with pytest.raises(
        ValidationError,
        match=r"with these overrides, press: states\.press\.command\.translation: magnitude must be <= 1 m",
    ):
        StateMachineParams(machine=spec, overrides={"a_far": 1.5})


def test_an_ending_says_its_transitions_why_unless_visits_ran_out() -> None:
    """A transition's `why` is what ending there means; when the state it leads to has used its
    visits and the machine fails instead, the record says so, not the why of the way it meant."""
    machine = base()
    machine["states"]["relieve"]["transitions"] = [{"to": "completed", "why": "pressed and relieved"}]
    machine["states"]["press"]["transitions"][1]["why"] = "not deep enough: press again"
    policy = policy_class(MachineSpec.model_validate(machine))()
    policy.first(HOME)
    policy.next(report(ExitCondition.WRENCH_BREACH, down(0.003)))
    done = policy.next(report(ExitCondition.COMPLETED, down(0.003)))
    assert done == Finish(True, "relieve ended completed: pressed and relieved")
    retried = policy_class(MachineSpec.model_validate(machine))()
    retried.first(HOME)
    for _ in range(2):
        retried.next(report(ExitCondition.TIMEOUT, HOME))
    ended = retried.next(report(ExitCondition.TIMEOUT, HOME))
    assert isinstance(ended, Finish) and ended.why.endswith("; press used its 3 visits: failed")


def test_a_machine_is_summed_up_by_its_summary_or_by_its_name() -> None:
    machine = base()
    assert policy_class(MachineSpec.model_validate(machine)).summary == "the machine 'press'"
    machine["summary"] = "press the plate, then let go"
    assert policy_class(MachineSpec.model_validate(machine)).summary == "press the plate, then let go"


def test_a_variable_not_set_is_said_by_name() -> None:
    """Validation refuses a read before every way there sets it; should one slip through, the
    machine fails saying which variable (not a bare KeyError)."""
    assert _refusal(KeyError("depth"), "ptwl") == "variable 'depth' not set yet"
    assert _refusal(OverflowError("too big"), "ptwl") == "too big"

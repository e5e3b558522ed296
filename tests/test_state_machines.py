"""Onboard state machines (paper 2.3): policies that choose the next behavior from the last
one's report, run headless, from the command line and on the robot as one command."""

import dataclasses
import json
import math
import subprocess
import threading
import time

import httpx
import numpy as np
import pytest

from ptwl.launcher import running_server
from robot_sim.behaviors import BehaviorReport, ExitCondition, Pose, Ptwl
from robot_sim.params import DitherParams, PtwlParams, RweParams
from robot_sim.policies import POLICIES, Finish, Machine, Policy, Step, run_onboard
from robot_sim.policies import run as run_module
from robot_sim.policies import sleeve_on_peg as sleeve
from robot_sim.policies.base import MAX_STEPS
from robot_sim.policies.sleeve_on_peg import SleeveOnPeg
from robot_sim.pose_math import rotation_matrix
from robot_sim.sim import Simulation
from server.client import RobotClient
from tests.command_line import run_ptwl
from tests.helpers import DOWN_WXYZ, completed_runs, report_down

HOME = Pose((0.378, 0.0, 0.266), DOWN_WXYZ)


def report(
    exit_condition: ExitCondition, depth_m: float, behavior: str = "ptwl", peak: float = 10.0
) -> BehaviorReport:
    return report_down(HOME, exit_condition, depth_m, behavior, peak)


# ------------------------------------------------------------------ the policy, report by report
def test_sleeve_policy_completes_when_the_insertion_ends_without_a_breach() -> None:
    policy = SleeveOnPeg()
    first = policy.first(HOME)
    assert isinstance(first.params, PtwlParams) and first.params == sleeve.INSERT
    decision = policy.next(report(ExitCondition.TIMEOUT, 0.058))
    assert isinstance(decision, Finish) and decision.completed and "58.0 mm" in decision.why


def jam(depth_m: float, torque_tool_xy: tuple[float, float]) -> BehaviorReport:
    """An insertion's breach `depth_m` down, the torque on the port about its tool x, y [N m]."""
    breach = report(ExitCondition.WRENCH_BREACH, depth_m, peak=27.0)
    R_world_port = rotation_matrix(np.asarray(HOME.quaternion))
    torque_world = R_world_port @ np.array([*torque_tool_xy, 0.0])
    return dataclasses.replace(breach, final_wrench=(0.0, 0.0, 25.0, *torque_world.tolist()))


def test_sleeve_policy_retracts_and_turns_the_approach_the_way_the_jams_torque_pushed() -> None:
    """Relieve, retract (a dither that ends on its progress), turn, insert again: each turn the
    way the jam's torque pushed, by the tilt that wedges the rigid fit at the jam's depth
    (2c / engagement), at most half the last one when it pushes back; then gives up."""
    policy = SleeveOnPeg()
    policy.first(HOME)
    R_world_port = rotation_matrix(np.asarray(HOME.quaternion))
    engaged_m = 0.0025  # of the peg's cylinder: wedges a 2.04 deg tilt
    depth_m = sleeve.MOUTH_M + sleeve.CHAMFER_M + engaged_m
    expected_tool_xy = [
        np.array([math.radians(2.04), 0.0]),  # the torque about tool +x: the full tilt
        np.array([0.0, math.radians(2.04)]),  # about +y: across the last, the full tilt
        np.array([0.0, -math.radians(1.02)]),  # about -y: back, half the last
    ]
    torques = [(0.2, 0.0), (0.0, 0.1), (0.0, -0.3)]
    for n in range(1, policy.settings.max_recoveries + 1):
        torque = torques[min(n, 3) - 1]
        relieve = policy.next(jam(depth_m, torque))
        assert isinstance(relieve, Step) and isinstance(relieve.params, RweParams)
        assert relieve.why.startswith("jam:") and f"({n})" in relieve.why and "27.0 N" in relieve.why
        assert f"{1000 * depth_m:.1f} mm" in relieve.why
        retract = policy.next(report(ExitCondition.COMPLETED, depth_m, "rwe"))
        assert isinstance(retract, Step) and isinstance(retract.params, DitherParams)
        assert retract.params.direction == "pull" and retract.params.progress == pytest.approx(0.004)
        turn = policy.next(report(ExitCondition.GOAL_REACHED, depth_m - 0.004, "dither"))
        assert isinstance(turn, Step) and isinstance(turn.params, PtwlParams)
        assert turn.params.frame == "base" and turn.params.orientation_tolerance <= 1e-3
        if n <= 3:
            so_far = sum(expected_tool_xy[:n], np.zeros(2))
            turned = R_world_port.T @ np.asarray(turn.params.rotation)  # from HOME's attitude
            assert turned[0:2] == pytest.approx(so_far, abs=math.radians(0.02)), np.degrees(turned)
            assert abs(turned[2]) < 1e-9
        insert = policy.next(report(ExitCondition.GOAL_REACHED, depth_m - 0.004, "ptwl"))
        assert isinstance(insert, Step) and insert.params == sleeve.INSERT
    assert policy.settings.max_recoveries == 8
    gave_up = policy.next(jam(depth_m, (0.1, 0.0)))
    assert isinstance(gave_up, Finish) and not gave_up.completed and "8 recoveries" in gave_up.why


@pytest.mark.parametrize("past_the_chamfer_m", [-0.0005, 0.0001])
def test_sleeve_policy_turns_one_degree_for_a_jam_on_the_chamfer(past_the_chamfer_m: float) -> None:
    """A jam on the chamfer, or at its edge (under 0.3 mm of cylinder in), says which way, not
    how far (2c / 0.1 mm would be 51 deg): 1 deg."""
    policy = SleeveOnPeg()
    policy.first(HOME)
    policy.next(jam(sleeve.MOUTH_M + sleeve.CHAMFER_M + past_the_chamfer_m, (0.0, 0.3)))
    policy.next(report(ExitCondition.COMPLETED, 0.02, "rwe"))
    turn = policy.next(report(ExitCondition.GOAL_REACHED, 0.017, "dither"))
    assert isinstance(turn, Step) and isinstance(turn.params, PtwlParams)
    turned = rotation_matrix(np.asarray(HOME.quaternion)).T @ np.asarray(turn.params.rotation)
    assert turned == pytest.approx([0.0, math.radians(1.0), 0.0], abs=1e-6)


def test_sleeve_policy_counts_a_breach_deep_enough_as_inserted() -> None:
    policy = SleeveOnPeg()
    policy.first(HOME)
    shallow = policy.next(report(ExitCondition.WRENCH_BREACH, sleeve.INSERTED_M - 0.001))
    assert isinstance(shallow, Step)  # a jam
    policy = SleeveOnPeg()
    policy.first(HOME)
    deep = policy.next(report(ExitCondition.WRENCH_BREACH, sleeve.INSERTED_M + 0.001))
    assert isinstance(deep, Finish) and deep.completed


# ------------------------------------------------------------------ the machine around a policy
def test_machine_ends_aborted_on_stop_and_fault_without_asking_the_policy() -> None:
    for ended in (ExitCondition.ABORTED, ExitCondition.FAULT):
        machine = Machine(SleeveOnPeg())
        machine.start(HOME)
        assert machine.advance(report(ended, 0.01)) is None
        assert machine.exit is ended and len(machine.steps) == 1
        assert machine.report().exit is ended


class Forever(Policy):
    """Never finishes: the machine must end it."""

    task = "forever"
    summary = "RWE, again and again"

    def first(self, port: Pose) -> Step:
        return Step(RweParams(), "start")

    def next(self, report: BehaviorReport) -> Step:
        return Step(RweParams(), "again")


def test_machine_fails_a_policy_that_never_finishes() -> None:
    machine = Machine(Forever())
    step = machine.start(HOME)
    while step is not None:
        step = machine.advance(report(ExitCondition.COMPLETED, 0.0, "rwe"))
    assert machine.exit is ExitCondition.FAILED and len(machine.steps) == MAX_STEPS == 60
    assert "still going" in machine.report().detail


class LongForever(Forever):
    """A machine that says it needs more steps (a tool exchange: 15 a cycle)."""

    def max_steps(self) -> int:
        return 75


def test_the_step_bound_is_the_machines_own() -> None:
    machine = Machine(LongForever())
    step = machine.start(HOME)
    while step is not None:
        step = machine.advance(report(ExitCondition.COMPLETED, 0.0, "rwe"))
    assert len(machine.steps) == 75 and machine.report().detail == "still going after 75 behaviors"


def test_machine_report_sums_up_its_steps() -> None:
    machine = Machine(SleeveOnPeg())
    machine.start(HOME)
    machine.advance(report(ExitCondition.WRENCH_BREACH, 0.02, peak=31.0))
    machine.advance(report(ExitCondition.COMPLETED, 0.02, "rwe", peak=4.0))
    machine.advance(report(ExitCondition.GOAL_REACHED, 0.04, "dither", peak=12.0))
    machine.advance(report(ExitCondition.COMPLETED, 0.04, "rwe", peak=12.0))
    assert machine.advance(report(ExitCondition.TIMEOUT, 0.058, peak=19.0)) is None
    whole = machine.report()
    assert whole.exit is ExitCondition.COMPLETED and whole.peak_force == 31.0
    metrics = run_module.trial_metrics(machine.steps)
    assert metrics["behaviors"] == 5 and metrics["rwe"] == 2 and metrics["dither"] == 1
    assert metrics["ptwl"] == {"timeout": 1, "goal_reached": 0, "wrench_breach": 1}


# ------------------------------------------------------------------ headless, on the physics
def test_seeded_runs_succeed_onboard_and_the_machine_agrees_with_the_predicate() -> None:
    runs = completed_runs("sleeve_on_peg")
    peaks = [r["max_force_n"] for r in runs]
    assert all(15.0 <= peak <= 25.0 for peak in peaks), peaks  # Table 3: ~19 N pressing on the bottom


def test_a_run_that_gives_up_is_failed_and_not_a_success() -> None:
    """The predicate's negative case: a jam the machine may not recover."""
    sim = Simulation("sleeve_on_peg")
    sim.run_behavior(Ptwl(PtwlParams(rotation=[np.radians(3.0), 0.0, 0.0], duration=1.0)))
    run = run_onboard("sleeve_on_peg", sim=sim, overrides={"max_recoveries": 0})
    assert run.end == "failed" and not run.success and run.progress < 0.030
    assert [s.report.exit for s in run.steps] == [ExitCondition.WRENCH_BREACH]


def test_task_command_line_runs_lists_and_benches() -> None:
    def ptwl(*args: str) -> subprocess.CompletedProcess[str]:
        return run_ptwl("task", *args, timeout=120)

    listed = ptwl("list")
    assert listed.returncode == 0 and "sleeve_on_peg" in listed.stdout
    one = ptwl("run", "sleeve_on_peg", "--seed", "3", "--json")
    assert one.returncode == 0, one.stderr
    trial = json.loads(one.stdout)
    assert trial["success"] is True and trial["end"] == "completed" and trial["behaviors"] == 1
    assert trial["ptwl"] == {"timeout": 1, "goal_reached": 0, "wrench_breach": 0}
    assert {"max_force_n", "max_torque_nm", "run_time_s", "rwe", "dither", "sim_time_s"} <= trial.keys()
    bench = ptwl("bench", "sleeve_on_peg", "--seeds", "2")
    assert (
        bench.returncode == 0
        and "| Success | 2 / 2 |" in bench.stdout
        and "PTWL (timeout) | 1.00" in bench.stdout
    )
    beside = bench.stdout.split("sleeve_on_peg beside the paper's Table 3")[1].splitlines()
    [force] = [line for line in beside if line.startswith("Max force [N]")]
    assert [cell.strip() for cell in force.split("|")][1:3] == ["18.8", "19.6"]  # the paper's, both links
    assert any("one PTWL ending `timeout`" in line for line in beside)  # why the shape is the same
    pneumatic = ptwl("run", "tool_retrieval", "--seed", "0", "--gripper-close-s", "0.0055", "--json")
    assert pneumatic.returncode == 0, pneumatic.stderr
    assert json.loads(pneumatic.stdout)["max_force_n"] > 30.0  # the closing impact: 37 N (15 N at 10 ms)
    no_gripper = ptwl("run", "sleeve_on_peg", "--gripper-close-s", "0.01")
    assert no_gripper.returncode == 2 and "sleeve_on_peg scene's tool has no gripper" in no_gripper.stderr
    bad = ptwl("run", "sleeve_on_peg", "--set", "max_recoveries=11")
    assert bad.returncode == 2 and "max_recoveries" in bad.stderr and "less than or equal to 10" in bad.stderr
    gave_up = ptwl(
        "run",
        "sleeve_on_peg",
        "--seed",
        "3",
        "--set",
        "insert_force_threshold=5",
        "--set",
        "max_recoveries=0",
    )
    assert (
        gave_up.returncode == 1 and "machine ended failed" in gave_up.stdout
    )  # breached at 5 N, no recovery
    unknown = ptwl("run", "no_such_task")
    assert unknown.returncode == 2 and "sleeve_on_peg" in unknown.stderr


# ------------------------------------------------------------------ on the robot, as one command
@pytest.fixture(scope="module")
def sleeve_server():  # type: ignore[no-untyped-def]
    with running_server("--scene", "sleeve_on_peg") as server:
        yield server


def test_state_machine_command_runs_onboard_announces_each_step_and_takes_overrides(sleeve_server) -> None:  # type: ignore[no-untyped-def]
    """The default run (one PTWL ending `timeout`, Table 3) is run from the console's Tasks tab in
    test_console_trust.py; here a 5 N insertion threshold (an override) ends it sooner, with a
    breach on the bottom the default would not have."""
    events: list[dict] = []
    with RobotClient(sleeve_server.url) as client:
        client.reset_scene("sleeve_on_peg")
        tasks = {t["name"]: t for t in httpx.get(sleeve_server.url + "/api/tasks").json()}
        assert list(tasks) == list(POLICIES)
        assert tasks["sleeve_on_peg"]["settings"]["max_recoveries"]["maximum"] == 10  # what may be set

        def listen() -> None:
            for message in client.telemetry(idle_s=0.5):
                if message["type"] == "command":
                    events.append(message)
                if events and events[-1]["status"] == "done":
                    return

        listener = threading.Thread(target=listen, daemon=True)
        listener.start()
        time.sleep(0.5)
        overrides = {"insert_force_threshold": 5.0, "max_recoveries": 0}
        accepted = client.command("state_machine", task="sleeve_on_peg", overrides=overrides)
        done = client.wait(accepted.id, timeout=30.0)
        listener.join(timeout=5.0)
    assert done.status == "done" and done.exit == "completed" and done.type == "state_machine"
    assert done.params["overrides"] == overrides
    assert [s.behavior for s in done.steps] == ["ptwl"] and "insert" in done.steps[0].why
    assert done.steps[0].params["force_threshold"] == 5.0 and done.steps[0].exit == "wrench_breach"
    assert "past the 50 mm mark" in done.detail and (done.peak_force or 0.0) < 12.0  # breach, not ~19 N
    mine = [e for e in events if e["id"] == accepted.id]
    # queued, running, the step (still running, now with its step), done: in that order.
    assert [(e["status"], len(e["steps"])) for e in mine] == [
        ("queued", 0),
        ("running", 0),
        ("running", 1),
        ("done", 1),
    ]


def test_stop_aborts_a_running_state_machine(sleeve_server) -> None:  # type: ignore[no-untyped-def]
    with RobotClient(sleeve_server.url) as client:
        client.reset_scene("sleeve_on_peg")
        accepted = client.command("state_machine", task="sleeve_on_peg")
        time.sleep(1.0)
        client.stop()
        done = client.wait(accepted.id, timeout=10.0)
    assert done.exit == "aborted" and [s.exit for s in done.steps] == ["aborted"]


@pytest.mark.parametrize(
    ("body", "fragment"),
    [
        ({"type": "state_machine", "task": "no_such_task"}, "task must be one of"),
        ({"type": "state_machine", "task": "sleeve_on_peg", "speed": 2}, "speed"),
        ({"type": "state_machine"}, "task"),
        (
            {"type": "state_machine", "task": "sleeve_on_peg", "overrides": {"max_recoveries": 11}},
            "max_recoveries",
        ),
        ({"type": "state_machine", "task": "sleeve_on_peg", "overrides": {"max_slides": 1}}, "max_slides"),
        ({"type": "state_machine", "task": "sleeve_on_peg", "overrides": {"max_recoveries": "2"}}, "integer"),
    ],
)
def test_a_bad_state_machine_request_is_refused_naming_the_field(
    sleeve_server, body: dict, fragment: str
) -> None:  # type: ignore[no-untyped-def]
    reply = httpx.post(sleeve_server.url + "/api/commands", json=body)
    assert reply.status_code == 422 and fragment in reply.text


def test_a_state_machine_for_another_scene_is_refused(sleeve_server) -> None:  # type: ignore[no-untyped-def]
    with RobotClient(sleeve_server.url) as client:
        client.reset_scene("surface")
        reply = httpx.post(
            sleeve_server.url + "/api/commands", json={"type": "state_machine", "task": "sleeve_on_peg"}
        )
        client.reset_scene("sleeve_on_peg")
    assert reply.status_code == 422 and "needs scene sleeve_on_peg; surface is loaded" in reply.text
    assert "task" in reply.json()["errors"][0]["field"]


def turns_after(jams: list[tuple[float, tuple[float, float]]]) -> list[np.ndarray]:
    """The approach (home's tool x, y [rad]) each round turns to, for jams (depth, torque)."""
    policy = SleeveOnPeg()
    policy.first(HOME)
    R_world_port = rotation_matrix(np.asarray(HOME.quaternion))
    approaches = []
    for depth_m, torque in jams:
        policy.next(jam(depth_m, torque))
        policy.next(report(ExitCondition.COMPLETED, depth_m, "rwe"))
        turn = policy.next(report(ExitCondition.GOAL_REACHED, depth_m - 0.004, "dither"))
        assert isinstance(turn, Step) and isinstance(turn.params, PtwlParams)
        approaches.append((R_world_port.T @ np.asarray(turn.params.rotation))[0:2])
        policy.next(report(ExitCondition.GOAL_REACHED, depth_m - 0.004, "ptwl"))
    return approaches


def test_sleeve_policy_keeps_its_approach_without_a_torque_and_turns_at_most_6_degrees_in_all() -> None:
    on_chamfer = sleeve.MOUTH_M + 0.001  # 1 deg a round
    still = turns_after([(on_chamfer, (0.0, 0.3)), (on_chamfer, (0.004, 0.0))])  # 4 mN m: no direction
    assert still[1] == pytest.approx(still[0], abs=1e-9)
    deep = sleeve.MOUTH_M + sleeve.CHAMFER_M + 0.0013  # each jam says 3.9 deg the same way
    far = turns_after([(deep, (0.3, 0.0))] * 3)
    assert np.degrees(np.linalg.norm(far[0])) == pytest.approx(3.92, abs=0.01)
    assert np.degrees(np.linalg.norm(far[2])) == pytest.approx(6.0, abs=1e-6)

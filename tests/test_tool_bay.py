"""Tool retrieval and stowage (paper 2.3.2-2.3.4): the gripper (a weld the jaws switch), the
closing impact, the bay's spring-loaded bayonet lock, and both state machines."""

import math

import httpx
import mujoco
import pytest

from robot_sim.behaviors import ExitCondition, Gripper, Ptwl, Rwe
from robot_sim.params import GripperParams, RweParams
from robot_sim.policies import run_onboard
from robot_sim.scenes.tool_bay import Bay, held, tool_qpos
from robot_sim.sim import Simulation
from server.client import RobotClient
from tests.helpers import completed_runs, ptwl_state

CLOSE, OPEN = Gripper(GripperParams(action="close")), GripperParams(action="open")
# robot_sim/machines/builtin/tool_retrieval.toml and tool_stowage.toml: the unlock turn (the
# tool's legs clear the bay's tabs past 0.52 rad).
TURN_OPEN_RAD = 0.8


def on_the_knob(seed: int | None = None) -> Simulation:
    """tool_retrieval with the gripper's pad brought down onto the tool's knob."""
    sim = Simulation("tool_retrieval", seed)
    report = sim.run_behavior(Ptwl(ptwl_state("tool_retrieval", "approach")))  # 40 mm down
    assert report.exit is ExitCondition.WRENCH_BREACH
    return sim


def lift(sim: Simulation) -> float:
    return Bay.of(sim.model).lift_m(sim.data)


# -------------------------------------------------------------------------- the gripper
def test_the_jaws_catch_only_what_is_between_them() -> None:
    sim = Simulation("tool_retrieval")
    empty = sim.run_behavior(Gripper(GripperParams(action="close")))  # the knob 20 mm below
    assert (
        empty.exit is ExitCondition.COMPLETED
        and "closed on nothing" in empty.detail
        and "20." in empty.detail
    )
    assert not held(sim)
    sim = on_the_knob()
    caught = sim.run_behavior(Gripper(GripperParams(action="close")))
    assert caught.detail.startswith("holding stow_tool") and held(sim)
    let_go = sim.run_behavior(Gripper(OPEN))
    assert let_go.detail == "released stow_tool" and not held(sim)


def test_closing_on_a_tool_2_mm_off_is_an_impact_that_an_rwe_relieves() -> None:
    """Paper 2.3.3: the jaws pull the part into the grasp, a closed chain through the arm; under
    compliance the robot gives, and an RWE takes the rest out."""
    sim = on_the_knob(seed=3)  # the bay 2 mm off
    impact = sim.run_behavior(Gripper(GripperParams(action="close")))
    assert "caught 2.0 mm off" in impact.detail
    lateral = math.hypot(*impact.final_wrench[0:2])
    assert impact.peak_force > 15.0 and lateral < 5.0  # a spike, mostly gone by the end
    relieved = sim.run_behavior(Rwe(RweParams(duration=1.0)))
    assert relieved.exit is ExitCondition.COMPLETED and math.hypot(*relieved.final_wrench[0:3]) < 1.0


# -------------------------------------------------------------------------- the lock
def test_a_locked_tool_will_not_lift_out() -> None:
    """The negative case: grasped but not turned, the legs meet the tabs: a breach, the tool in."""
    sim = on_the_knob()
    sim.run_behavior(Gripper(GripperParams(action="close")))
    sim.run_behavior(Rwe(RweParams(duration=1.0)))
    report = sim.run_behavior(Ptwl(ptwl_state("tool_retrieval", "extract")))  # 60 mm up
    assert report.exit is ExitCondition.WRENCH_BREACH and lift(sim) < 0.012
    assert not sim.task().success


def test_the_lock_spring_turns_a_released_tool_back_under_the_tabs() -> None:
    sim = on_the_knob()
    sim.run_behavior(Gripper(GripperParams(action="close")))
    turned = sim.run_behavior(Ptwl(ptwl_state("tool_retrieval", "unlock")))  # -TURN_OPEN_RAD
    assert turned.exit is ExitCondition.GOAL_REACHED
    assert math.degrees(Bay.of(sim.model).turn_rad(sim.data)) > 40.0
    assert 0.3 < turned.final_wrench[5] * -1 < 0.6  # the spring's 0.6 N m/rad, held by the port
    sim.run_behavior(Gripper(OPEN))
    sim.run(1.0)
    assert abs(math.degrees(Bay.of(sim.model).turn_rad(sim.data))) < 5.0 and lift(sim) < 0.001


def test_a_stowed_and_locked_tool_still_in_the_gripper_is_not_stowed() -> None:
    """The predicate's last clause: bottomed and locked is not enough until the jaws let go."""
    sim = Simulation("tool_stowage")
    for params in (
        ptwl_state("tool_stowage", "approach"),  # 30 mm down
        ptwl_state("tool_stowage", "unlock"),  # -TURN_OPEN_RAD
        ptwl_state("tool_stowage", "bottom"),  # 30 mm down
        ptwl_state("tool_stowage", "lock", turned=-TURN_OPEN_RAD),  # +TURN_OPEN_RAD
    ):
        sim.run_behavior(Ptwl(params))
    bay = Bay.of(sim.model)
    assert bay.lift_m(sim.data) < 0.001 and abs(bay.turn_rad(sim.data)) < 0.15 and held(sim)
    assert not sim.task().success
    sim.run_behavior(Gripper(OPEN))
    assert sim.task().success


def test_a_bay_out_of_reach_fails_stowage_and_is_not_counted() -> None:
    """A deliberately failed run: the bay 12 mm off, the tool lands on its rim."""
    sim = Simulation("tool_stowage")
    sim.model.body("bay").pos[0] += 0.012
    run = run_onboard("tool_stowage", sim=sim)
    assert run.end == "failed" and not run.success


# -------------------------------------------------------------------------- the machines
@pytest.mark.parametrize("task", ["tool_retrieval", "tool_stowage"])
def test_seeded_runs_retrieve_and_stow_onboard(task: str) -> None:
    runs = completed_runs(task)
    assert all(r["max_force_n"] <= 40.0 for r in runs), [r["max_force_n"] for r in runs]
    assert all(r["gripper"] == 1 for r in runs)
    grips = [s for r in runs for s in r["steps"] if s["behavior"] == "gripper"]
    assert all(s["detail"].startswith("holding" if task == "tool_retrieval" else "released") for s in grips)


# -------------------------------------------------------------------------- the API
def test_a_gripper_command_needs_a_tool_with_a_gripper(robot: RobotClient) -> None:
    reply = httpx.post(robot.base_url + "/api/commands", json={"type": "gripper", "action": "close"})
    assert reply.status_code == 422 and "free_space scene's tool has no gripper" in reply.text
    bad = httpx.post(robot.base_url + "/api/commands", json={"type": "gripper", "action": "squeeze"})
    assert bad.status_code == 422 and "action" in bad.text
    robot.reset_scene("tool_retrieval")
    try:
        accepted = robot.command("gripper", action="close")
        done = robot.wait(accepted.id, timeout=10.0)
        assert done.exit == "completed" and "closed on nothing" in done.detail
    finally:
        robot.reset_scene("free_space")


def test_the_bay_calls_a_tool_out_only_in_the_gripper_and_stowed_only_let_go() -> None:
    """The retrieval's predicate and the exchange's witness read these: a tool lifted out of
    the bay by anything but the gripper is not retrieved; a locked tool still held is not stowed."""
    sim = Simulation("tool_retrieval")
    bay = Bay.of(sim.model)
    assert bay.stowed(sim.data) and not bay.out(sim.data) and not bay.held(sim.data)
    sim.data.eq_active[bay.grasp] = 1  # the jaws on the tool, where it lies locked
    assert not bay.stowed(sim.data) and not bay.out(sim.data)
    sim.data.qpos[tool_qpos(sim.model) + 2] += 0.05  # 50 mm up, out of the bay
    mujoco.mj_forward(sim.model, sim.data)
    assert bay.lift_m(sim.data) > 0.04 and bay.out(sim.data)
    sim.data.eq_active[bay.grasp] = 0  # the same place, not in the gripper
    assert not bay.out(sim.data) and not sim.task().success

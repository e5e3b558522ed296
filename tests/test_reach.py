"""A PTWL whose goal the arm cannot reach says so when it is accepted (which joint, by how much,
or how far out of reach), and the controller then stops where that said (issue 29, point 3)."""

import re
from pathlib import Path

import mujoco
import numpy as np
import pytest
from fastapi.testclient import TestClient

from robot_sim.behaviors.base import ExitCondition
from robot_sim.behaviors.ptwl import Ptwl, ptwl_goal
from robot_sim.params import PtwlParams
from robot_sim.reach import reach_warnings
from robot_sim.sim import Simulation
from server.app import create_app
from server.config import ServerConfig

NEEDS_JOINT = re.compile(
    r"the goal needs joint (\d) at ([+-]\d+) deg, (\d+) deg past its (lower|upper) end \(([+-]\d+) deg\)"
)
STALLS = re.compile(r"out of the arm's reach from where it is: a walk toward it stalls (\d+) mm from it")


def warned(sim: Simulation, params: PtwlParams) -> list[str]:
    ctl = sim.controller
    goal = ptwl_goal(ctl.p_world_port, ctl.q_world_port, params, sim.frames)
    return reach_warnings(sim.model, sim.data, sim.layout, *goal)


@pytest.mark.parametrize(
    "move", [{"translation": [0.05, 0, 0]}, {"rotation": [0, 0, 3.0]}, {"translation": [0.1, 0.1, -0.1]}]
)
def test_a_goal_in_reach_gets_no_warning_and_is_reached(move: dict[str, list[float]]) -> None:
    sim = Simulation("free_space")
    params = PtwlParams(duration=3.0, **move)
    assert warned(sim, params) == []
    assert sim.run_behavior(Ptwl(params)).exit is ExitCondition.GOAL_REACHED


def test_a_turn_past_the_wrists_range_names_the_joint_and_by_how_much() -> None:
    sim = Simulation("free_space")
    params = PtwlParams(rotation=[3.1, 0, 0], duration=5.0)
    said = {int(m[1]): m for w in warned(sim, params) if (m := NEEDS_JOINT.search(w))}
    assert 5 in said, said
    needed_deg, past_deg, end, end_deg = int(said[5][2]), int(said[5][3]), said[5][4], int(said[5][5])
    assert (end, end_deg) == ("upper", 120) and needed_deg - end_deg == pytest.approx(past_deg, abs=1)
    assert past_deg > 10
    # And there the port stops: the controller's taper holds joint 5 at that end.
    report = sim.run_behavior(Ptwl(params))
    assert report.exit is ExitCondition.TIMEOUT and "joint 5 at its upper end" in report.detail


def test_a_goal_out_of_reach_says_how_far_and_the_port_stops_about_there() -> None:
    sim = Simulation("free_space")
    params = PtwlParams(translation=[0.3, 0, 0], frame="base", duration=5.0)
    [warning] = warned(sim, params)
    stall_mm = float(STALLS.search(warning)[1])  # type: ignore[index]
    ptwl = Ptwl(params)
    report = sim.run_behavior(ptwl)
    short_mm = 1000.0 * float(np.linalg.norm(ptwl.p_world_goal - sim.controller.p_world_port))
    assert report.exit is ExitCondition.TIMEOUT
    assert stall_mm == pytest.approx(short_mm, rel=0.10) and short_mm > 50.0


def test_a_walk_that_stalls_is_given_up_then_not_walked_to_its_200_steps(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Every PTWL sent is checked so: out of reach, the walk stops once 20 steps gain under
    0.1 mm (measured: 38 steps for 0.3 m out, against the 200 it may take)."""
    sim = Simulation("free_space")
    params = PtwlParams(translation=[0.3, 0, 0], frame="base", duration=5.0)
    steps = []
    real_kinematics = mujoco.mj_kinematics
    monkeypatch.setattr(mujoco, "mj_kinematics", lambda m, d: steps.append(1) or real_kinematics(m, d))
    [warning] = warned(sim, params)
    assert STALLS.search(warning) and 20 < len(steps) < 100, len(steps)


def test_the_api_answers_an_unreachable_ptwl_with_its_warning(tmp_path: Path) -> None:
    app = create_app(ServerConfig(scene="free_space", data_dir=tmp_path, allow_hosts=("testserver",)))
    with TestClient(app) as client:
        far = client.post("/api/commands", json={"type": "ptwl", "rotation": [3.1, 0, 0], "duration": 5})
        near = client.post("/api/commands", json={"type": "ptwl", "translation": [0.01, 0, 0]})
    assert far.status_code == near.status_code == 202
    assert any(NEEDS_JOINT.search(w) and "joint 5" in w for w in far.json()["warnings"]), far.json()
    assert near.json()["warnings"] == []

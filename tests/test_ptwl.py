"""PTWL ends with each of its exit conditions in a scene that forces it."""

import numpy as np
import pytest

from robot_sim.behaviors.base import ExitCondition
from robot_sim.behaviors.ptwl import Ptwl
from robot_sim.params import PtwlParams
from robot_sim.pose_math import angle_between
from robot_sim.sim import Simulation

GAP_TO_PLATE = 0.0466 - 0.008  # [m] port height above the plate at home minus the tip radius


def test_goal_reached_in_free_space_with_tool_frame_motion() -> None:
    sim = Simulation("free_space")
    start = sim.state().port
    params = PtwlParams(translation=[0.03, -0.02, 0.04], rotation=[0.0, 0.2, 0.1], frame="tool", duration=2.0)
    report = sim.run_behavior(Ptwl(params))
    assert report.exit is ExitCondition.GOAL_REACHED
    # Tool frame: the displacement is rotated by the port's orientation at start (tool z = base -z).
    moved = np.array(report.final_port.position) - np.array(start.position)
    np.testing.assert_allclose(moved, [-0.03, -0.02, -0.04], atol=params.position_tolerance)
    assert report.peak_force < 1.0  # free space: only inertial residue
    # It cannot finish before the attractor arrives, nor much after (5 time constants).
    assert 2.0 <= report.duration <= 2.0 + 5 * 0.5


def test_base_frame_rotation_turns_about_the_port_origin() -> None:
    sim = Simulation("free_space")
    p0 = sim.controller.p_world_port.copy()
    q0 = sim.controller.q_world_port.copy()
    report = sim.run_behavior(Ptwl(PtwlParams(rotation=[0.0, 0.0, 0.3], frame="base", duration=1.0)))
    assert report.exit is ExitCondition.GOAL_REACHED
    assert np.linalg.norm(np.array(report.final_port.position) - p0) < 0.002
    assert angle_between(np.array(report.final_port.quaternion), q0, np.zeros(3)) == pytest.approx(
        0.3, abs=0.02
    )


def test_wrench_breach_on_the_plate_freezes_the_attractor_and_bounds_the_force() -> None:
    sim = Simulation("surface")
    threshold = 15.0
    # 40 mm past the plate: with K = 2000 N/m the press would reach 80 N; the threshold stops it.
    # ~10 mm/s, quasi-static as in the paper's tasks (a faster impact overshoots in one tick).
    params = PtwlParams(translation=[0, 0, GAP_TO_PLATE + 0.04], duration=8.0, force_threshold=threshold)
    report = sim.run_behavior(Ptwl(params))
    assert report.exit is ExitCondition.WRENCH_BREACH
    assert report.peak_force == pytest.approx(threshold, rel=0.15)
    frozen = sim.controller.p_world_attractor.copy()
    forces = []
    for _ in range(2000):  # 2 s after the breach
        sim.step()
        forces.append(sim.controller.force_norm)
    np.testing.assert_array_equal(sim.controller.p_world_attractor, frozen)
    assert max(forces) < 1.2 * threshold
    assert forces[-1] > 0.5 * threshold  # still pressing: frozen, not released


def test_timeout_when_the_goal_is_behind_the_plate() -> None:
    sim = Simulation("surface")
    # 5 mm past the plate: 10 N, under the threshold, and the goal is never reached.
    params = PtwlParams(
        translation=[0, 0, GAP_TO_PLATE + 0.005], duration=1.0, force_threshold=40.0, watchdog=3.0
    )
    report = sim.run_behavior(Ptwl(params))
    assert report.exit is ExitCondition.TIMEOUT
    assert report.duration == pytest.approx(3.0, abs=0.002)
    assert report.final_wrench[2] == pytest.approx(2000 * 0.005, rel=0.05)


def test_stiffness_preset_is_applied_for_the_move() -> None:
    sim = Simulation("free_space")
    sim.run_behavior(Ptwl(PtwlParams(translation=[0.01, 0, 0], preset="stiff")))
    np.testing.assert_array_equal(sim.controller.gains.stiffness, [4000, 4000, 4000, 200, 200, 200])
    explicit = PtwlParams(
        translation=[0.01, 0, 0], stiffness=[900, 900, 900, 30, 30, 30], damping=[900] * 3 + [30] * 3
    )
    sim.run_behavior(Ptwl(explicit))
    np.testing.assert_array_equal(sim.controller.gains.damping, [900, 900, 900, 30, 30, 30])


def test_abort_ends_aborted_and_freezes() -> None:
    sim = Simulation("free_space")
    sim.start(Ptwl(PtwlParams(translation=[0.1, 0, 0], duration=4.0)))
    sim.run(1.0)
    report = sim.abort()
    assert report is not None and report.exit is ExitCondition.ABORTED
    frozen = sim.controller.p_world_attractor.copy()
    sim.run(0.5)
    np.testing.assert_array_equal(sim.controller.p_world_attractor, frozen)

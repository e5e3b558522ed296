"""A wrench limit that holds: `on_breach: limit` keeps the held force at the threshold at any
approach speed and preset; `freeze` is the paper's literal rule, and holds about B v past it."""

import math

import numpy as np
import pytest

from robot_sim.behaviors import Dither, ExitCondition, Ptwl
from robot_sim.impact import impact_warnings
from robot_sim.params import DitherParams, PtwlParams
from robot_sim.presets import default_presets
from robot_sim.scenes import sleeve_insertion_depth
from robot_sim.sim import Simulation
from robot_sim.task_frames import TaskFrames
from tests.test_ptwl import GAP_TO_PLATE

THRESHOLD_N = 15.0


def held_after_breach(preset: str, speed: float, on_breach: str) -> tuple[float, float]:
    """(peak, mean held force 1-1.5 s after the breach) for an 80 mm-past-the-plate PTWL [N]."""
    sim = Simulation("surface")
    distance = GAP_TO_PLATE + 0.08
    params = PtwlParams(
        translation=[0, 0, distance],
        duration=distance / speed,
        force_threshold=THRESHOLD_N,
        preset=preset,
        on_breach=on_breach,
    )
    report = sim.run_behavior(Ptwl(params))
    assert report.exit is ExitCondition.WRENCH_BREACH
    sim.run(1.0)
    held = [sim.controller.force_norm for _ in range(500) if sim.step() is None]
    return report.peak_force, float(np.mean(held))


@pytest.mark.parametrize("preset", ["stiff", "medium", "soft"])
@pytest.mark.parametrize("speed", [0.02, 0.04, 0.08, 0.16])
def test_limit_holds_the_threshold_at_every_speed_and_preset(preset: str, speed: float) -> None:
    peak, held = held_after_breach(preset, speed, "limit")
    assert held <= 1.10 * THRESHOLD_N
    assert held >= 0.85 * THRESHOLD_N  # still pressing: limited, not released
    assert peak >= THRESHOLD_N  # the impact itself is physics, reported as the peak


def test_freeze_is_the_papers_rule_and_holds_about_b_v() -> None:
    damping = default_presets().stiffness_preset("medium").damping[2]
    _, held = held_after_breach("medium", 0.08, "freeze")
    assert held == pytest.approx(damping * 0.08, rel=0.2)  # ~66 N against 15 N
    assert held > 3 * THRESHOLD_N


def test_on_breach_defaults_to_limit() -> None:
    assert PtwlParams().on_breach == "limit"
    assert DitherParams().on_breach == "limit"


def test_torque_threshold_ends_a_rotation_against_the_peg() -> None:
    sim = Simulation("sleeve_on_peg")
    sim.run_behavior(Ptwl(PtwlParams(translation=[0, 0, 0.04], duration=4.0, force_threshold=40)))
    assert sleeve_insertion_depth(sim) > 0.015
    # Tilting the inserted sleeve levers against the peg: torque, with little force.
    report = sim.run_behavior(
        Ptwl(PtwlParams(rotation=[0.2, 0, 0], duration=4.0, force_threshold=200.0, torque_threshold=1.0))
    )
    assert report.exit is ExitCondition.WRENCH_BREACH
    assert report.peak_torque > 1.0
    assert float(np.linalg.norm(report.final_wrench[0:3])) < 200.0
    sim.run(1.0)
    assert sim.controller.torque_norm <= 1.10  # limited: the held torque stays at the threshold


def test_dither_breaches_on_the_plate_and_limits() -> None:
    sim = Simulation("surface")
    sim.run_behavior(Ptwl(PtwlParams(translation=[0, 0, GAP_TO_PLATE - 0.002], duration=3.0)))
    push = DitherParams(preset="translational_push", travel=0.02, force_threshold=10.0)
    report = sim.run_behavior(Dither(push))
    assert report.exit is ExitCondition.WRENCH_BREACH
    sim.run(1.0)
    assert sim.controller.force_norm <= 1.10 * 10.0


def test_dither_times_out_when_it_cannot_travel() -> None:
    sim = Simulation("surface")
    touch = PtwlParams(translation=[0, 0, GAP_TO_PLATE + 0.001], duration=3.0, watchdog=4.0)
    sim.run_behavior(Ptwl(touch))
    # 5 mm of travel into the plate builds only K x 5 mm = 10 N: no breach, and no progress.
    params = DitherParams(preset="translational_push", travel=0.005, duration=1.0, watchdog=2.0)
    report = sim.run_behavior(Dither(params))
    assert report.exit is ExitCondition.TIMEOUT
    assert report.duration == pytest.approx(2.0, abs=0.002)


def test_impact_warning_when_b_v_passes_the_threshold() -> None:
    medium = default_presets().stiffness_preset("medium").to_gains()
    tool_down = [0.0, 1.0, 0.0, 0.0]  # tool z = base -z
    fast = PtwlParams(translation=[0, 0, 0.1], duration=1.0, force_threshold=15.0)
    (warning,) = impact_warnings(fast, medium, tool_down, TaskFrames())
    assert "~100 N" in warning and "force_threshold 15 N" in warning and ">= 6.67 s" in warning
    slow = PtwlParams(translation=[0, 0, 0.1], duration=7.0, force_threshold=15.0)
    assert impact_warnings(slow, medium, tool_down, TaskFrames()) == []
    spin = PtwlParams(rotation=[0, 0, math.pi / 2], duration=1.0, torque_threshold=2.0)
    (torque_warning,) = impact_warnings(spin, medium, tool_down, TaskFrames())
    assert "torque_threshold 2 N m" in torque_warning

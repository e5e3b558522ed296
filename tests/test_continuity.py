"""Attractor continuity (docs/architecture.md, behaviors): no start, preemption or STOP jerks a held force.

A press held at 15 N on the plate must survive any command's start, a preemption and STOP to
within 10 % over the first 50 ms; after a breach a PTWL pushing further is "stuck" (breaches
again within a few ticks) until an RWE relieves it (paper 2.2.2).
"""

import numpy as np
import pytest

from robot_sim.behaviors import Behavior, Dither, ExitCondition, Ptwl, Rwe
from robot_sim.params import DitherParams, PtwlParams, RweParams
from robot_sim.presets import default_presets
from robot_sim.sim import Simulation
from tests.test_ptwl import GAP_TO_PLATE

PRESS_N = 15.0


def pressing() -> Simulation:
    """The probe pressing the plate at ~15 N, held by the breach limit."""
    sim = Simulation("surface")
    report = sim.run_behavior(
        Ptwl(PtwlParams(translation=[0, 0, GAP_TO_PLATE + 0.03], duration=6.0, force_threshold=PRESS_N))
    )
    assert report.exit is ExitCondition.WRENCH_BREACH
    sim.run(1.0)
    assert sim.controller.w_world_env_on_port[2] == pytest.approx(PRESS_N, rel=0.05)
    return sim


def force_z_over(sim: Simulation, seconds: float) -> np.ndarray:
    out = []
    for _ in range(round(seconds / sim.control_dt)):
        sim.step()
        out.append(float(sim.controller.w_world_env_on_port[2]))
    return np.array(out)


def assert_force_kept(sim: Simulation, before: float) -> None:
    """The press stays within 10 % of `before` over the next 50 ms."""
    assert np.max(np.abs(force_z_over(sim, 0.05) - before)) < 0.10 * before


def sliding_on_the_plate(seconds: float) -> tuple[Simulation, float]:
    """Pressing, then a lateral PTWL for `seconds`; the simulation and the press now [N]."""
    sim = pressing()
    sim.start(Ptwl(LATERAL))
    sim.run(seconds)
    before = float(sim.controller.w_world_env_on_port[2])
    assert before > 0.5 * PRESS_N
    return sim, before


LATERAL = PtwlParams(translation=[0.02, 0, 0], frame="base", duration=4.0, force_threshold=40)
STARTS: dict[str, Behavior] = {
    "ptwl_lateral": Ptwl(LATERAL),
    "ptwl_up": Ptwl(PtwlParams(translation=[0, 0, -0.01], duration=4.0, force_threshold=40)),
    "dither_torsional": Dither(DitherParams(preset="torsional_push", force_threshold=40)),
    "dither_translational": Dither(DitherParams(preset="translational_pull", force_threshold=40)),
}


@pytest.mark.parametrize("name", list(STARTS))
def test_starting_a_command_keeps_the_held_force(name: str) -> None:
    sim = pressing()
    before = float(sim.controller.w_world_env_on_port[2])
    p_attractor = sim.controller.p_world_attractor.copy()
    sim.start(STARTS[name])
    sim.step()
    # The attractor starts where it was (at most one tick of the behavior's own motion).
    assert np.linalg.norm(sim.controller.p_world_attractor - p_attractor) < 1e-4
    assert_force_kept(sim, before)


def test_preemption_keeps_the_held_force_and_ends_the_first_aborted() -> None:
    sim, before = sliding_on_the_plate(0.5)
    preempted = sim.start(Dither(DitherParams(preset="translational_push", force_threshold=40)))
    assert preempted is not None and preempted.exit is ExitCondition.ABORTED
    assert preempted.detail == "preempted"
    assert_force_kept(sim, before)


def test_stop_keeps_the_press_and_stops_free_motion() -> None:
    sim, before = sliding_on_the_plate(0.3)
    report = sim.hold_position()
    assert report is not None and report.exit is ExitCondition.ABORTED and report.detail == "stopped"
    assert_force_kept(sim, before)
    assert float(np.mean(force_z_over(sim, 1.0)[-100:])) == pytest.approx(before, rel=0.10)
    # In free space STOP holds the port: the attractor goes on the port, the arm stops.
    sim = Simulation("free_space")
    sim.start(Ptwl(PtwlParams(translation=[0.1, 0, 0], duration=2.0)))
    sim.run(1.0)
    sim.hold_position()
    held = sim.controller.p_world_port.copy()
    sim.run(1.0)
    assert np.linalg.norm(sim.controller.p_world_port - held) < 0.003


def test_after_a_breach_pushing_further_is_stuck_until_an_rwe() -> None:
    sim = pressing()
    push = PtwlParams(translation=[0, 0, 0.01], duration=2.0, force_threshold=PRESS_N)
    again = sim.run_behavior(Ptwl(push))
    assert again.exit is ExitCondition.WRENCH_BREACH
    assert again.duration < 0.02  # "stuck every time a force threshold were crossed"
    relieved = sim.run_behavior(Rwe(RweParams(duration=1.0)))
    assert relieved.exit is ExitCondition.COMPLETED
    assert sim.controller.force_norm < 0.1 * PRESS_N
    # After the RWE the same push has 7.5 mm of stretch to build before it breaches.
    later = sim.run_behavior(Ptwl(push))
    assert later.duration > 0.2


def test_rwe_on_x_y_then_a_lateral_ptwl_keeps_the_insertion_force() -> None:
    sim = pressing()
    assert sim.run_behavior(Rwe(RweParams(axes=["x", "y"], duration=1.0))).exit is ExitCondition.COMPLETED
    before = float(sim.controller.w_world_env_on_port[2])
    assert before == pytest.approx(PRESS_N, rel=0.10)
    # The goal keeps the stretch that holds the press (the plug strategy, paper 2.3.7): the force
    # survives the start and the whole slide.
    keep_z = -before / sim.controller.gains.stiffness[2]
    slide = PtwlParams(translation=[0.015, 0, keep_z], frame="base", duration=3.0, force_threshold=40)
    sim.start(Ptwl(slide))
    forces = force_z_over(sim, 3.5)
    assert np.max(np.abs(forces[:50] - before)) < 0.10 * before
    assert np.mean(forces[-500:]) == pytest.approx(before, rel=0.15)


def test_attractor_path_has_no_jumps_across_commands() -> None:
    sim = Simulation("free_space")
    ctl = sim.controller
    sequence: list[Behavior] = [
        Ptwl(PtwlParams(translation=[0.05, 0, 0], duration=2.0)),
        Dither(DitherParams(preset="translational_push")),
        Ptwl(PtwlParams(rotation=[0, 0.3, 0], duration=2.0)),
        Dither(DitherParams(preset="torsional_pull")),
    ]
    previous_p = ctl.p_world_attractor.copy()
    previous_q = ctl.q_world_attractor.copy()
    worst_p, worst_q = 0.0, 0.0
    for behavior in sequence:
        sim.start(behavior)  # preempts the previous one mid-way
        for _ in range(700):
            sim.step()
            worst_p = max(worst_p, float(np.linalg.norm(ctl.p_world_attractor - previous_p)))
            worst_q = max(worst_q, float(np.linalg.norm(ctl.q_world_attractor - previous_q)))
            previous_p[:] = ctl.p_world_attractor
            previous_q[:] = ctl.q_world_attractor
    assert worst_p < 1e-4  # [m] per tick: <= 0.1 m/s, no jump
    assert worst_q < 1e-3  # quaternion change per tick: < 2 mrad


PRESETS = list(default_presets().stiffness)


@pytest.mark.parametrize(("held_by", "changed_to"), [(a, b) for a in PRESETS for b in PRESETS if a != b])
def test_a_preset_changed_in_contact_keeps_the_held_force(held_by: str, changed_to: str) -> None:
    """The paper's bumpless transition, "also employed when the robot was in contact with
    non-zero forces" (2.3.2), for a command that brings new gains: the attractor is placed again
    for the new K. (Kept where it was, soft -> stiff stepped a 15 N press to 118 N.)"""
    sim = pressing()
    hold = PtwlParams(translation=[0, 0, 0], duration=0.5, force_threshold=40, preset=held_by)
    sim.run_behavior(Ptwl(hold))
    sim.run(0.5)
    before = float(sim.controller.w_world_env_on_port[2])
    assert before == pytest.approx(PRESS_N, rel=0.10)  # held by `held_by`'s stiffness
    sim.start(Ptwl(hold.model_copy(update={"preset": changed_to})))
    assert_force_kept(sim, before)
    assert float(np.mean(force_z_over(sim, 0.5))) == pytest.approx(before, rel=0.10)
    expected = default_presets().stiffness_preset(changed_to).to_gains()
    assert np.array_equal(sim.controller.gains.stiffness, expected.stiffness)  # taken, not kept
    assert np.array_equal(sim.controller.gains.damping, expected.damping)


def test_a_stiffer_move_along_the_plate_starts_without_breaching() -> None:
    """Issue 29's case: pressing at 15 N, a stiff PTWL 10 mm along and 7.5 mm into the plate
    (15 N threshold) breached 1 ms after its start at 22.1 N; it now starts from the force held."""
    sim = pressing()
    before = float(sim.controller.w_world_env_on_port[2])
    move = PtwlParams(translation=[0.01, 0, 0.0075], frame="base", duration=2.0, force_threshold=20)
    sim.start(Ptwl(move.model_copy(update={"preset": "stiff"})))
    assert_force_kept(sim, before)
    assert sim.behavior is not None  # still running: no breach at the start


def test_damping_or_axes_alone_changed_are_taken_and_keep_the_press() -> None:
    sim = pressing()
    before = float(sim.controller.w_world_env_on_port[2])
    damping = (2.0 * sim.controller.gains.damping).tolist()
    stiffness = sim.controller.gains.stiffness.tolist()
    hold = PtwlParams(translation=[0, 0, 0], stiffness=stiffness, damping=damping, force_threshold=40)
    sim.start(Ptwl(hold))
    assert_force_kept(sim, before)
    assert sim.controller.gains.damping.tolist() == damping
    # The same diagonal in the tool's axes (the probe points down: K's axes turn, not its size).
    sim.run(0.5)
    before = float(sim.controller.w_world_env_on_port[2])
    sim.start(Ptwl(hold.model_copy(update={"gains_frame": "tool"})))
    assert_force_kept(sim, before)
    assert sim.controller.gains.frame == "tool"


@pytest.mark.parametrize("changed_to", ["stiff", "soft"])
def test_a_preset_changed_mid_move_neither_stops_nor_reverses_the_arm(changed_to: str) -> None:
    """Moving, the spring pulls B v: carried over, the port keeps its speed (balancing the
    measured wrench instead dropped the pull: 0.09 m/s fell to 0.04 in 10 ms, then reversed)."""
    sim = Simulation("free_space")
    sim.start(Ptwl(PtwlParams(translation=[0.1, 0, 0], frame="base", duration=1.0, preset="medium")))
    x_m = []
    for _ in range(500):
        sim.step()
        x_m.append(float(sim.controller.p_world_port[0]))
    v_before = (x_m[-1] - x_m[-11]) / 0.010
    assert v_before > 0.05  # [m/s] under way
    sim.start(Ptwl(PtwlParams(translation=[0.05, 0, 0], frame="base", duration=0.5, preset=changed_to)))
    for _ in range(60):
        sim.step()
        x_m.append(float(sim.controller.p_world_port[0]))
    v_after = np.diff(x_m[-61:]) / sim.control_dt
    assert float(np.min(v_after)) > 0.7 * v_before

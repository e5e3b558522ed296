"""RWE relieves contact wrenches; the axis-selective variant keeps the others' stretch."""

import mujoco
import numpy as np
import pytest

from robot_sim.behaviors.base import ExitCondition
from robot_sim.behaviors.ptwl import Ptwl
from robot_sim.behaviors.rwe import Rwe
from robot_sim.params import PtwlParams, RweParams
from robot_sim.pose_math import rotation_matrix
from robot_sim.sim import Simulation
from tests.test_ptwl import GAP_TO_PLATE


def pressed_on_plate(lateral: float = 0.0) -> Simulation:
    """The probe pressed into the plate after a breach: down (base -z) and optionally sideways."""
    sim = Simulation("surface")
    params = PtwlParams(
        translation=[lateral, 0.0, -(GAP_TO_PLATE + 0.03)], frame="base", duration=2.0, force_threshold=30.0
    )
    report = sim.run_behavior(Ptwl(params))
    assert report.exit is ExitCondition.WRENCH_BREACH
    sim.run(0.5)
    return sim


def test_rwe_relieves_a_breach_to_under_ten_percent() -> None:
    sim = pressed_on_plate()
    before = sim.controller.force_norm
    assert before > 20.0
    report = sim.run_behavior(Rwe(RweParams(duration=1.0)))
    assert report.exit is ExitCondition.COMPLETED
    assert sim.controller.force_norm < 0.1 * before
    # Relieved "without substantially changing the robot pose" (paper 2.2.2).
    assert abs(report.final_port.position[2] - 0.228) < 0.002


def test_rwe_on_x_y_keeps_the_z_force() -> None:
    # Pressed down while dragging sideways: friction loads x as well as z.
    sim = pressed_on_plate(lateral=0.01)
    w = sim.controller.w_world_env_on_port
    fz_before, fx_before = float(w[2]), float(w[0])
    assert abs(fx_before) > 1.0
    report = sim.run_behavior(Rwe(RweParams(axes=["x", "y"], duration=1.5)))
    assert report.exit is ExitCondition.COMPLETED
    assert report.final_wrench[2] == pytest.approx(fz_before, rel=0.10)
    assert abs(report.final_wrench[0]) < 0.1 * abs(fx_before)


def test_rwe_times_out_when_the_environment_keeps_pushing() -> None:
    sim = pressed_on_plate()
    # Residual below what a still-settling press can reach in 1 ms: the exit says "not relieved".
    report = sim.run_behavior(Rwe(RweParams(duration=0.001, force_residual=0.01)))
    assert report.exit is ExitCondition.TIMEOUT


def test_hold_position_aborts_and_puts_the_attractor_on_the_port() -> None:
    sim = Simulation("free_space")
    sim.start(Ptwl(PtwlParams(translation=[0.1, 0.0, 0.0], duration=3.0)))
    sim.run(1.0)
    report = sim.hold_position()
    assert report is not None and report.exit is ExitCondition.ABORTED
    held = sim.controller.p_world_port.copy()
    sim.run(1.0)
    # The port coasts to a stop within a few mm (it was moving at ~35 mm/s) and stays.
    assert float(((sim.controller.p_world_port - held) ** 2).sum() ** 0.5) < 0.005
    moved = sim.controller.p_world_port.copy()
    sim.run(1.0)
    assert float(((sim.controller.p_world_port - moved) ** 2).sum() ** 0.5) < 1e-4


def inserted_sleeve() -> Simulation:
    sim = Simulation("sleeve_on_peg")
    sim.run_behavior(Ptwl(PtwlParams(translation=[0, 0, 0.04], duration=4.0, force_threshold=40)))
    return sim


@pytest.mark.parametrize("axis", ["rx", "ry", "rz"])
def test_rwe_on_one_rotation_axis_relieves_it_and_keeps_the_others(axis: str) -> None:
    sim = inserted_sleeve()
    ctl = sim.controller
    i = ["rx", "ry", "rz"].index(axis)
    # Turn the attractor about the axis (and push down a little): stretch on every axis.
    rotation = [0.0, 0.0, 0.0]
    rotation[i] = 0.03
    sim.run_behavior(
        Ptwl(
            PtwlParams(rotation=rotation, translation=[0, 0, 0.003], frame="base", duration=0.5, watchdog=1.0)
        )
    )
    ctl.measure_stretch()
    before = ctl.stretch_world()
    assert abs(before[3 + i]) > 0.005
    report = sim.run_behavior(Rwe(RweParams(axes=[axis], duration=1.0, torque_residual=0.3)))
    assert report.exit is ExitCondition.COMPLETED
    after = ctl.stretch_world()
    assert abs(after[3 + i]) < 1e-6  # the attractor sits on the port about this axis
    kept = [j for j in range(6) if j != 3 + i]
    np.testing.assert_allclose(after[kept], before[kept], atol=2e-3 * 0.03)
    assert abs(report.final_wrench[3 + i]) <= 0.3


def test_rwe_in_tool_axes_keeps_the_force_along_a_tilted_tool() -> None:
    sim = Simulation("surface")
    sim.run_behavior(Ptwl(PtwlParams(rotation=[0.3, 0, 0], frame="base", duration=1.0)))
    press = PtwlParams(translation=[0.0, 0.0, GAP_TO_PLATE + 0.03], duration=4.0, force_threshold=12.0)
    assert sim.run_behavior(Ptwl(press)).exit is ExitCondition.WRENCH_BREACH
    sim.run(0.5)
    ctl = sim.controller
    tool_z = np.zeros(9)
    mujoco.mju_quat2Mat(tool_z, ctl.q_world_port)
    axis = tool_z.reshape(3, 3)[:, 2]
    along_before = float(ctl.w_world_env_on_port[0:3] @ axis)
    assert abs(along_before) > 5.0
    sim.run_behavior(Rwe(RweParams(axes=["x", "y", "rx", "ry", "rz"], frame="tool", duration=1.5)))
    assert float(ctl.w_world_env_on_port[0:3] @ axis) == pytest.approx(along_before, rel=0.15)


def test_rwe_axes_in_tool_frame_are_the_ports_axes() -> None:
    sim = Simulation("free_space")
    sim.run_behavior(Ptwl(PtwlParams(rotation=[0.4, 0.3, 0], frame="base", duration=1.0)))
    ctl = sim.controller
    R_world_port = rotation_matrix(ctl.q_world_port)
    ctl.p_world_attractor[:] = ctl.p_world_port + R_world_port @ [0.004, 0.003, 0.002]
    sim.start(Rwe(RweParams(axes=["x"], frame="tool", duration=0.5)))
    sim.step()
    stretch_tool = R_world_port.T @ ctl.stretch_world()[0:3]
    assert abs(stretch_tool[0]) < 1e-4  # tool x relieved
    np.testing.assert_allclose(stretch_tool[1:], [0.003, 0.002], atol=2e-4)  # tool y, z kept

"""Gains diagonal in base or tool axes, and the precomposed map checked against eq. 5 + DLS."""

import mujoco
import numpy as np
import pytest

from robot_sim.behaviors import ExitCondition, Ptwl
from robot_sim.controller import LAMBDA_FLOOR_SQ, LAMBDA_MAX, MANIPULABILITY_THRESHOLD, Limit
from robot_sim.gains import Gains
from robot_sim.params import PtwlParams
from robot_sim.sim import Simulation
from tests.helpers import fit_time_constant

# Anisotropic in tool axes: tau = B/K = 1.0, 0.4, 0.25 s along tool x, y, z.
TOOL_K = [1000.0, 2500.0, 4000.0, 100.0, 100.0, 100.0]
TOOL_B = [1000.0, 1000.0, 1000.0, 50.0, 50.0, 50.0]


def tilted_tool() -> Simulation:
    sim = Simulation("free_space")
    tilt = PtwlParams(rotation=[0.5, 0.3, 0.0], frame="base", duration=1.5)
    assert sim.run_behavior(Ptwl(tilt)).exit is ExitCondition.GOAL_REACHED
    return sim


@pytest.mark.parametrize("axis", [0, 1, 2])
def test_time_constant_is_b_over_k_along_a_tilted_tools_axes(axis: int) -> None:
    sim = tilted_tool()
    ctl = sim.controller
    ctl.set_gains(Gains.of(TOOL_K, TOOL_B, "tool"))
    sim.run(0.3)
    R_world_port = ctl.gains_rotation()
    direction = R_world_port[:, axis]
    assert abs(direction @ [1.0, 0.0, 0.0]) < 0.99 and abs(direction @ [0.0, 0.0, 1.0]) < 0.99  # tilted
    ctl.p_world_attractor[:] = ctl.p_world_port + 0.01 * direction
    times, along, across = [], [], []
    for _ in range(3000):
        sim.step()
        stretch = ctl.p_world_attractor - ctl.p_world_port
        times.append(sim.time)
        along.append(float(stretch @ direction))
        across.append(float(np.linalg.norm(stretch - (stretch @ direction) * direction)))
    tau = TOOL_B[axis] / TOOL_K[axis]
    assert fit_time_constant(np.array(times) - times[0], np.array(along)) == pytest.approx(tau, rel=0.05)
    assert max(across) < 0.05 * 0.01  # moves along the tool axis, not across it


def test_base_frame_gains_on_the_same_tilt_mix_the_axes() -> None:
    """Control for the test above: the same diagonal in base axes couples the tool axes."""
    sim = tilted_tool()
    ctl = sim.controller
    ctl.set_gains(Gains.of(TOOL_K, TOOL_B, "base"))
    sim.run(0.3)
    direction = ctl.gains_rotation()  # identity for base gains
    R_world_port = np.zeros(9)
    mujoco.mju_quat2Mat(R_world_port, ctl.q_world_port)
    tool_y = R_world_port.reshape(3, 3)[:, 1]
    assert np.allclose(direction, np.eye(3))
    ctl.p_world_attractor[:] = ctl.p_world_port + 0.01 * tool_y
    sim.run(0.2)
    stretch = ctl.p_world_attractor - ctl.p_world_port
    assert np.linalg.norm(stretch - (stretch @ tool_y) * tool_y) > 0.05 * 0.01


@pytest.mark.parametrize("frame", ["base", "tool"])
def test_precomposed_map_is_dls_of_eq5_at_random_configurations(frame: str) -> None:
    rng = np.random.default_rng(11)
    checked = 0
    for _ in range(40):
        qpos = np.array([0.0, 0.3, 0.2, 0.0, 1.07, 0.0]) + rng.uniform(-0.6, 0.6, 6)
        k = rng.uniform(200.0, 3000.0, 6) * np.array([1, 1, 1, 0.05, 0.05, 0.05])
        b = k * rng.uniform(0.3, 2.0, 6)
        sim = Simulation("free_space", gains=Gains.of(k, b, frame), qpos=tuple(qpos))
        ctl = sim.controller
        adr = sim.layout.ft_sensor_adr
        # Signals small enough that no drive limit binds in one tick from rest (40 rad/s^2).
        sim.data.sensordata[adr : adr + 6] += rng.uniform(-0.3, 0.3, 6)
        ctl.measure()
        ctl.p_world_attractor += rng.uniform(-3e-4, 3e-4, 3)
        ctl.refresh_kinematics()
        ctl.command()
        if ctl.limited in (Limit.SPEED, Limit.JOINT_LIMIT):
            continue  # these change qdot on purpose; the singularity's DLS damping is checked
        checked += 1
        J = np.zeros((6, 6))
        mujoco.mj_jacSite(sim.model, sim.data, J[0:3], J[3:6], sim.layout.port_site)
        m = float(np.sqrt(np.linalg.det(J @ J.T)))
        ratio = m / MANIPULABILITY_THRESHOLD
        lam_sq = LAMBDA_FLOOR_SQ + (LAMBDA_MAX**2 * (1 - ratio**2) if ratio < 1 else 0.0)
        R = np.eye(3)
        if frame == "tool":
            R = sim.data.site_xmat[sim.layout.port_site].reshape(3, 3)
        rot = np.block([[R, np.zeros((3, 3))], [np.zeros((3, 3)), R]])
        K = rot @ np.diag(k) @ rot.T
        B = rot @ np.diag(b) @ rot.T
        twist = np.linalg.solve(B, ctl.control_wrench() + K @ ctl.stretch_world())
        expected = J.T @ np.linalg.solve(J @ J.T + lam_sq * np.eye(6), twist)
        np.testing.assert_allclose(ctl.qdot_cmd, expected, rtol=1e-6, atol=1e-9)
        np.testing.assert_allclose(ctl.twist_des(), twist, rtol=1e-9, atol=1e-12)
    assert checked >= 20


def test_bumpless_start_in_tool_frame_balances_the_press() -> None:
    sim = Simulation("surface")
    sim.run_behavior(Ptwl(PtwlParams(translation=[0, 0, 0.045], duration=4.0, force_threshold=12.0)))
    sim.run(1.0)
    ctl = sim.controller
    before = ctl.w_world_env_on_port.copy()
    ctl.set_gains(Gains.of([3000, 1000, 2000, 100, 100, 100], [1000] * 3 + [50] * 3, "tool"))
    ctl.balance(ctl.control_wrench())
    assert np.abs(ctl.twist_des()).max() < 1e-9
    sim.run(0.5)
    assert ctl.w_world_env_on_port[2] == pytest.approx(before[2], rel=0.05)


def test_a_ptwl_chooses_the_gains_frame() -> None:
    sim = Simulation("free_space")
    medium = sim.controller.gains
    sim.run_behavior(Ptwl(PtwlParams(translation=[0.01, 0, 0], gains_frame="tool")))
    assert sim.controller.gains.frame == "tool"
    np.testing.assert_array_equal(sim.controller.gains.stiffness, medium.stiffness)  # same diagonal
    sim.run_behavior(Ptwl(PtwlParams(translation=[0.01, 0, 0], preset="soft")))
    assert sim.controller.gains.frame == "base"  # the preset's frame
    sim.run_behavior(Ptwl(PtwlParams(translation=[0.01, 0, 0])))
    assert sim.controller.gains.frame == "base"  # unchanged when the PTWL says nothing

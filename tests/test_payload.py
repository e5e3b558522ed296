"""Tool weight compensation: at rest in free space the compensated wrench is ~zero."""

import mujoco
import numpy as np
import pytest

from robot_sim.payload import Payload
from robot_sim.sim import Simulation

WRIST_POSES = {
    "tool_down": (0.0, 0.3, 0.2, 0.0, 1.0708, 0.0),
    "tool_horizontal": (0.0, 0.3, 0.2, 0.0, -0.5, 0.0),
    "rolled": (0.3, 0.2, 0.3, 1.2, 0.8, 0.7),
    "tool_up_tilted": (-0.4, 0.1, -0.2, -1.0, -1.6, 2.0),
    "sideways": (0.8, 0.4, 0.0, 1.57, 1.0, -1.2),
}


@pytest.mark.parametrize(
    "scene", ["free_space", "sleeve_on_peg", "quick_connect", "lid", "plug", "socket_wrench"]
)
@pytest.mark.parametrize("pose", list(WRIST_POSES))
def test_compensated_wrench_at_rest_is_zero(scene: str, pose: str) -> None:
    sim = Simulation(scene, qpos=WRIST_POSES[pose])
    sim.run(1.0)
    raw_force = np.linalg.norm(sim.data.sensordata[sim.layout.ft_sensor_adr : sim.layout.ft_sensor_adr + 3])
    assert raw_force == pytest.approx(sim.payload.mass_kg * 9.81, rel=0.01)  # the sensor does see the tool
    assert sim.controller.force_norm < 0.05
    assert sim.controller.torque_norm < 0.005


def test_payload_calibration_read_from_the_model() -> None:
    sim = Simulation("free_space")
    payload = Payload.from_model(sim.model, sim.layout)
    assert payload.mass_kg == pytest.approx(0.5)
    np.testing.assert_allclose(payload.com_ft, [0.004, 0.0, 0.045], atol=1e-12)
    np.testing.assert_allclose(payload.port_ft, [0.0, 0.0, 0.110], atol=1e-12)


def test_compensation_refers_torque_to_the_port() -> None:
    """A pure force at the port gives no torque about the port, whatever the lever to the sensor."""
    sim = Simulation("free_space")
    payload = sim.payload
    M = payload.compensation_matrix()
    f_env_ft = np.array([3.0, -2.0, 5.0])
    # Sensor reading for that force at the port plus the tool's weight, at an arbitrary orientation.
    R_world_ft = np.zeros(9)
    mujoco.mju_quat2Mat(R_world_ft, np.array([0.8, 0.2, -0.4, 0.4]) / np.linalg.norm([0.8, 0.2, -0.4, 0.4]))
    g_ft = R_world_ft.reshape(3, 3).T @ np.array([0.0, 0.0, -9.81])
    weight = payload.mass_kg * g_ft
    f_sensor = -(f_env_ft + weight)
    tau_sensor = -(np.cross(payload.port_ft, f_env_ft) + np.cross(payload.com_ft, weight))
    w = M @ np.concatenate([f_sensor, tau_sensor, g_ft])
    np.testing.assert_allclose(w[0:3], f_env_ft, atol=1e-12)
    np.testing.assert_allclose(w[3:6], 0.0, atol=1e-12)


def test_a_sensor_set_off_its_body_and_turned_measures_from_its_own_origin() -> None:
    """Every shipped tool has its sensor at the tool body's origin, so a sensor offset read with
    the wrong sign would not show there: offset and turn it, and compare with the same figures
    taken in the world (the sites as MuJoCo places them)."""
    sim = Simulation("free_space")
    model, layout = sim.model, sim.layout
    model.site_pos[layout.ft_site] += [0.003, -0.002, 0.01]
    model.site_quat[layout.ft_site] = [np.cos(0.3), 0.0, 0.0, np.sin(0.3)]  # 0.6 rad about z
    model.site_sameframe[layout.ft_site] = 0  # else MuJoCo still places it at the body's frame
    payload = Payload.from_model(model, layout)
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    mujoco.mj_comPos(model, data)
    R_world_ft = data.site_xmat[layout.ft_site].reshape(3, 3)
    p_world_ft = data.site_xpos[layout.ft_site]
    com_world = data.subtree_com[layout.tool_body]
    np.testing.assert_allclose(payload.com_ft, R_world_ft.T @ (com_world - p_world_ft), atol=1e-12)
    port_world = data.site_xpos[layout.port_site]
    np.testing.assert_allclose(payload.port_ft, R_world_ft.T @ (port_world - p_world_ft), atol=1e-12)

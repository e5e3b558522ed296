"""Contact: with the attractor past the rigid plate, the press settles at K times the overshoot."""

import mujoco
import numpy as np
import pytest

from robot_sim.gains import Gains
from robot_sim.sim import Simulation

PLATE_TOP_Z = 0.220  # [m] surface.xml
TIP_RADIUS = 0.008  # [m] probe.xml: the port is the ball's centre


def contact_force_world(sim: Simulation) -> np.ndarray:
    """Sum of MuJoCo's contact forces on the tool, base axes [N]."""
    m, d = sim.model, sim.data
    tool_geoms = {g for g in range(m.ngeom) if m.geom_bodyid[g] == sim.layout.tool_body}
    total = np.zeros(3)
    wrench_contact = np.zeros(6)
    for i in range(d.ncon):
        con = d.contact[i]
        mujoco.mj_contactForce(m, d, i, wrench_contact)
        # Contact frame rows are the normal and tangents (world); the force acts on geom2.
        f_world = con.frame.reshape(3, 3).T @ wrench_contact[0:3]
        if con.geom2 in tool_geoms:
            total += f_world
        elif con.geom1 in tool_geoms:
            total -= f_world
    return total


@pytest.mark.parametrize(("stiffness_z", "overshoot"), [(1000.0, 0.010), (2000.0, 0.005), (4000.0, 0.004)])
def test_press_settles_at_stiffness_times_overshoot(stiffness_z: float, overshoot: float) -> None:
    k = [stiffness_z, stiffness_z, stiffness_z, 100, 100, 100]
    sim = Simulation("surface", gains=Gains.of(k, [1000, 1000, 1000, 50, 50, 50]))
    ctl = sim.controller
    ctl.p_world_attractor[2] = PLATE_TOP_Z + TIP_RADIUS - overshoot
    sim.run(2.0 + 8 * 1000 / stiffness_z)
    expected = stiffness_z * overshoot
    forces = []
    for _ in range(200):
        sim.step()
        forces.append(ctl.w_world_env_on_port[2])
    assert np.mean(forces) == pytest.approx(expected, rel=0.02)
    assert np.std(forces) < 0.002 * expected  # settled, no chatter
    # The sensor (payload removed) agrees with MuJoCo's own contact force.
    contact = contact_force_world(sim)
    assert contact[2] == pytest.approx(ctl.w_world_env_on_port[2], rel=0.01)
    assert np.linalg.norm(contact - ctl.w_world_env_on_port[0:3]) < 0.01 * expected
    # The port sits on the plate (soft contact: a few hundredths of a mm inside).
    assert ctl.p_world_port[2] - TIP_RADIUS == pytest.approx(PLATE_TOP_Z, abs=2e-4)


def test_free_space_reads_no_contact_force() -> None:
    sim = Simulation("surface")
    sim.run(0.5)
    assert sim.data.ncon == 0
    assert np.linalg.norm(contact_force_world(sim)) == 0.0
    assert sim.controller.force_norm < 0.05

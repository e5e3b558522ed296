"""Force/torque payload compensation: from the raw wrist reading to the environment's wrench.

MuJoCo's force/torque sensors report the wrench the parent (flange) exerts on the child (tool)
about the sensor site, in the site frame. At rest, that wrench holds up the tool's weight.
Real F/T systems subtract a calibrated payload (mass, centre of mass); here the calibration is
read from the model once, and only the current sensor orientation is used per tick.

For a quasi-static tool (inertial terms ignored, as real payload compensation does), the
environment's wrench on the tool, referred to the port of interaction and in sensor axes, is
linear in [f_s, tau_s, g_ft] (g_ft = gravity in sensor axes):

    f_env          = -f_s - m g_ft
    tau_env@port   = -tau_s - d x f_s - m (c + d) x g_ft

with c the centre of mass and d = p_ft - p_port, both constant in sensor axes. So one constant
(6, 9) matrix maps the raw reading to the compensated wrench.
"""

from dataclasses import dataclass

import mujoco
import numpy as np

from robot_sim.arm import ArmLayout
from robot_sim.pose_math import rotation_matrix


def _skew(v: np.ndarray) -> np.ndarray:
    """(3, 3) matrix S with S @ u = v x u."""
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


@dataclass(frozen=True)
class Payload:
    """The tool below the sensor, as a calibration would know it."""

    mass_kg: float
    com_ft: np.ndarray  # (3,) [m] centre of mass in sensor axes, from the sensor origin
    port_ft: np.ndarray  # (3,) [m] port origin in sensor axes, from the sensor origin

    @staticmethod
    def from_model(model: mujoco.MjModel, layout: ArmLayout) -> "Payload":
        body = layout.tool_body
        # The tool's whole subtree (a detent ball on its own joint counts), at the model's
        # reference pose: a calibration weighs the tool once, as it hangs.
        data = mujoco.MjData(model)
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        R_world_body = data.xmat[body].reshape(3, 3)
        com_body = R_world_body.T @ (data.subtree_com[body] - data.xpos[body])
        # Sensor and port sites are on the tool body; express both in the sensor frame.
        R_body_ft = rotation_matrix(model.site_quat[layout.ft_site])
        p_body_ft = model.site_pos[layout.ft_site]
        com_ft = R_body_ft.T @ (com_body - p_body_ft)
        port_ft = R_body_ft.T @ (model.site_pos[layout.port_site] - p_body_ft)
        return Payload(float(model.body_subtreemass[body]), com_ft, port_ft)

    def compensation_matrix(self) -> np.ndarray:
        """(6, 9) map from [f_s, tau_s, g_ft] to the environment's wrench at the port, sensor axes."""
        d = -self.port_ft  # from port to sensor origin
        M = np.zeros((6, 9))
        M[0:3, 0:3] = -np.eye(3)
        M[0:3, 6:9] = -self.mass_kg * np.eye(3)
        M[3:6, 0:3] = -_skew(d)
        M[3:6, 3:6] = -np.eye(3)
        M[3:6, 6:9] = -self.mass_kg * _skew(self.com_ft + d)
        return M

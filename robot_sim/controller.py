"""Admittance controller with a virtual attractor (paper section 2.1.1, eq. 1-5).

Per control tick:

    w      = wrench of the environment on the port, base axes (sensor, payload removed)
    s      = stretch: attractor (-) port; position difference and rotation vector, base axes
    t_des  = B^-1 (w + K s)                                   (eq. 5, K and B diagonal)
    qdot   = J^T (J J^T + lambda^2 I)^-1 t_des                 (damped least squares)

then joint velocities are scaled to the joint speed limits and tapered near joint limits,
and sent to the joint servos (ctrl = qdot for both the integrated-velocity and the velocity
feed-forward servo). K and B are diagonal in base-frame axes.

The tick runs at 1 kHz with the physics, so it is written against preallocated buffers with
mujoco.mju_* calls (a handful of microseconds) rather than NumPy expressions, which allocate.
"""

import math

import mujoco
import numpy as np

from robot_sim.arm import ArmLayout
from robot_sim.errors import SimulationFault
from robot_sim.gains import Gains
from robot_sim.payload import Payload

GRAVITY_CHECK_TOL = 1e-9
# Damped least squares: lambda^2 grows from 0 to LAMBDA_MAX^2 as the manipulability
# sqrt(det(J J^T)) falls below MANIPULABILITY_THRESHOLD (Chiaverini's singularity-robust
# inverse). Far from singularities the inverse is exact, so the free-space response stays the
# designed first-order lag.
MANIPULABILITY_THRESHOLD = 0.004
LAMBDA_MAX = 0.08
LAMBDA_FLOOR_SQ = 1e-10
# Within this distance of a joint limit [rad], motion toward it is tapered linearly to zero.
JOINT_LIMIT_MARGIN_RAD = 0.15
# Slow checks (manipulability, non-finite values, joint-limit proximity) every N ticks.
HOUSEKEEPING_TICKS = 10


class AdmittanceController:
    """Turns the stretch to the attractor and the sensed wrench into joint-velocity commands."""

    def __init__(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        layout: ArmLayout,
        payload: Payload,
        gains: Gains,
    ) -> None:
        self.model = model
        self.data = data
        self.layout = layout
        self.enabled = False

        # Views into MjData (stable for the data's lifetime; refreshed by mj_step1).
        self._R_world_ft = data.site_xmat[layout.ft_site]  # (9,)
        self._R_world_port = data.site_xmat[layout.port_site]  # (9,)
        self.p_world_port = data.site_xpos[layout.port_site]  # (3,) [m], read only
        a = layout.ft_sensor_adr
        self._raw_wrench_ft = data.sensordata[a : a + 6]  # force (3) [N], torque (3) [N m]
        self._qpos = data.qpos[layout.qpos_adr[0] : layout.qpos_adr[0] + 6]
        self._ctrl_pos = data.ctrl[layout.ctrl_pos]
        self._ctrl_vel = data.ctrl[layout.ctrl_vel]

        # Attractor pose, base frame. Behaviors write these in place.
        self.p_world_attractor = np.zeros(3)  # [m]
        self.q_world_attractor = np.array([1.0, 0.0, 0.0, 0.0])  # [w x y z]
        self.q_world_port = np.array([1.0, 0.0, 0.0, 0.0])

        # ws = [w_world_env_on_port (6), stretch (6)]: eq. 5 is one (6, 12) matrix product.
        self._ws = np.zeros(12)
        self.w_world_env_on_port = self._ws[0:6]  # [N, N m] base axes, torque about the port
        self.stretch = self._ws[6:12]  # [m, rad] base axes
        self._sensor_and_gravity = np.zeros(9)  # [f_s, tau_s, g_ft]
        self._w_ft = np.zeros(6)
        self._gravity_world = np.array(model.opt.gravity)
        self._compensation = payload.compensation_matrix()  # (6, 9)
        self._rot_err_port = np.zeros(3)
        self._eq5 = np.zeros((6, 12))  # [diag(1/B) diag(K/B)]
        self.twist_des = np.zeros(6)  # [m/s, rad/s] base axes

        self._jac = np.zeros((6, model.nv))  # (6, nv) rows: linear then angular, world axes
        self._jacp = self._jac[0:3]
        self._jacr = self._jac[3:6]
        self._jjt = np.zeros((6, 6))
        self._jjt_flat = self._jjt.reshape(36)
        self._lambda_eye = np.zeros(36)
        self._y = np.zeros(6)
        self.qdot_cmd = np.zeros(6)  # [rad/s]
        self._abs_ratio = np.zeros(6)
        self._inv_speed_limit = 1.0 / layout.joint_speed_limit
        self._lower_soft = layout.joint_range[:, 0] + 2 * JOINT_LIMIT_MARGIN_RAD
        self._upper_soft = layout.joint_range[:, 1] - 2 * JOINT_LIMIT_MARGIN_RAD
        self._near_joint_limit = False
        self._ticks = 0
        self.manipulability = 0.0
        self.speed_scale = 1.0  # last uniform scale applied for joint speed limits (<= 1)
        self.gains = gains
        self.set_gains(gains)
        self._set_lambda(0.0)

    # ----------------------------------------------------------------------------- gains
    def set_gains(self, gains: Gains) -> None:
        """Take new stiffness/damping; the attractor stays, so the virtual wrench may step."""
        self.gains = gains
        inv_b = 1.0 / gains.damping
        self._eq5[:, 0:6] = np.diag(inv_b)
        self._eq5[:, 6:12] = np.diag(gains.stiffness * inv_b)

    def _set_lambda(self, manipulability: float) -> None:
        ratio = manipulability / MANIPULABILITY_THRESHOLD
        lam_sq = LAMBDA_MAX**2 * (1.0 - ratio * ratio) if ratio < 1.0 else 0.0
        self._lambda_eye[::7] = lam_sq + LAMBDA_FLOOR_SQ

    # ------------------------------------------------------------------------ measuring
    def measure(self) -> None:
        """Port orientation and compensated wrench from the current MjData (after mj_step1)."""
        sg = self._sensor_and_gravity
        mujoco.mju_copy(sg[0:6], self._raw_wrench_ft)
        mujoco.mju_mulMatTVec3(sg[6:9], self._R_world_ft, self._gravity_world)
        mujoco.mju_mulMatVec(self._w_ft, self._compensation, sg)
        ws = self._ws
        mujoco.mju_mulMatVec3(ws[0:3], self._R_world_ft, self._w_ft[0:3])
        mujoco.mju_mulMatVec3(ws[3:6], self._R_world_ft, self._w_ft[3:6])
        mujoco.mju_mat2Quat(self.q_world_port, self._R_world_port)

    def _measure_stretch(self) -> None:
        ws = self._ws
        mujoco.mju_sub3(ws[6:9], self.p_world_attractor, self.p_world_port)
        # mju_subQuat gives the error in the port's frame; rotate it into base axes.
        mujoco.mju_subQuat(self._rot_err_port, self.q_world_attractor, self.q_world_port)
        mujoco.mju_mulMatVec3(ws[9:12], self._R_world_port, self._rot_err_port)

    # ---------------------------------------------------------------------------- ticks
    def tick(self) -> None:
        """One control period with a fixed attractor: measure, then command."""
        self.measure()
        self.command()

    def command(self) -> None:
        """Stretch to the (possibly just moved) attractor, eq. 5, DLS, limits, servo commands."""
        self._measure_stretch()
        self._ticks += 1
        if self._ticks % HOUSEKEEPING_TICKS == 0:
            self._housekeeping()
        if not self.enabled:
            return
        mujoco.mju_mulMatVec(self.twist_des, self._eq5, self._ws)
        mujoco.mj_jacSite(self.model, self.data, self._jacp, self._jacr, self.layout.port_site)
        jac = self._jac if self.model.nv == 6 else np.ascontiguousarray(self._jac[:, 0:6])
        mujoco.mju_mulMatMatT(self._jjt, jac, jac)
        mujoco.mju_addTo(self._jjt_flat, self._lambda_eye)
        mujoco.mju_cholFactor(self._jjt, 0.0)
        mujoco.mju_cholSolve(self._y, self._jjt, self.twist_des)
        qdot = self.qdot_cmd
        mujoco.mju_mulMatTVec(qdot, jac, self._y)
        self._limit_joint_speeds(qdot)
        mujoco.mju_copy(self._ctrl_pos, qdot)
        mujoco.mju_copy(self._ctrl_vel, qdot)

    def _limit_joint_speeds(self, qdot: np.ndarray) -> None:
        # Scale all joints together so the Cartesian direction is kept.
        ratio = self._abs_ratio
        np.abs(qdot, out=ratio)
        ratio *= self._inv_speed_limit
        peak = ratio.max()
        self.speed_scale = 1.0 if peak <= 1.0 else 1.0 / peak
        if peak > 1.0:
            qdot *= self.speed_scale
        if self._near_joint_limit:
            self._taper_at_joint_limits(qdot)

    def _taper_at_joint_limits(self, qdot: np.ndarray) -> None:
        """Slow each joint toward its limit linearly over the last margin: it stops, never hits."""
        q = self._qpos
        lo = self.layout.joint_range[:, 0]
        hi = self.layout.joint_range[:, 1]
        vmax = self.layout.joint_speed_limit
        for i in range(6):
            if qdot[i] > 0.0:
                room = (hi[i] - q[i]) / JOINT_LIMIT_MARGIN_RAD
                qdot[i] = min(qdot[i], vmax[i] * max(0.0, min(1.0, room)))
            elif qdot[i] < 0.0:
                room = (q[i] - lo[i]) / JOINT_LIMIT_MARGIN_RAD
                qdot[i] = max(qdot[i], -vmax[i] * max(0.0, min(1.0, room)))

    def _housekeeping(self) -> None:
        if not (math.isfinite(self._ws.sum()) and math.isfinite(self._qpos.sum())):
            raise SimulationFault("non-finite wrench, stretch or joint position")
        q = self._qpos
        self._near_joint_limit = bool(np.any(q < self._lower_soft) or np.any(q > self._upper_soft))
        mujoco.mj_jacSite(self.model, self.data, self._jacp, self._jacr, self.layout.port_site)
        jac = self._jac[:, 0:6]
        self.manipulability = math.sqrt(max(0.0, float(np.linalg.det(jac @ jac.T))))
        self._set_lambda(self.manipulability)

    # ------------------------------------------------------------------ attractor moves
    def enable(self) -> None:
        """Start compliance bumplessly: place the attractor so K s balances the measured wrench.

        In equilibrium w + K s = 0, so s = -K^-1 w; on axes with (near) zero stiffness no
        stretch can hold a force and the attractor is put on the port there.
        """
        self.measure()
        self._measure_stretch()
        k = self.gains.stiffness
        stretch = np.where(k > 1e-9, -self.w_world_env_on_port / np.maximum(k, 1e-9), 0.0)
        self.place_attractor_from_port(stretch)
        self.enabled = True

    def disable(self) -> None:
        """Position hold: the servos keep their last integrated reference."""
        self.enabled = False
        self.qdot_cmd[:] = 0.0
        self._ctrl_pos[:] = 0.0
        self._ctrl_vel[:] = 0.0

    def place_attractor_from_port(self, stretch: np.ndarray) -> None:
        """Attractor = port (+) stretch: translation and base-axes rotation vector (6,)."""
        self.p_world_attractor[:] = self.p_world_port + stretch[0:3]
        q_delta = quat_from_rotvec(stretch[3:6])
        mujoco.mju_mulQuat(self.q_world_attractor, q_delta, self.q_world_port)


def quat_from_rotvec(rotvec: np.ndarray) -> np.ndarray:
    """Unit quaternion [w x y z] of a rotation vector [rad]."""
    quat = np.array([1.0, 0.0, 0.0, 0.0])
    mujoco.mju_quatIntegrate(quat, np.ascontiguousarray(rotvec, dtype=float), 1.0)
    return quat

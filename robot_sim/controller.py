"""Admittance controller with a virtual attractor (paper section 2.1.1, eq. 1-5).

Per control tick:

    w      = wrench of the environment on the port, base axes (sensor, payload removed)
    s      = stretch: attractor (-) port; position difference and rotation vector
    t_des  = B^-1 (w + K s)                                   (eq. 5, K and B diagonal, base axes)
    qdot   = J^T (J J^T + lambda^2 I)^-1 t_des                 (damped least squares)

then joint velocities are held to the joint speed and acceleration limits and tapered near
joint limits, and sent to the joint servos (ctrl = qdot for the integrated-velocity and the
feed-forward servo).

Multi-rate, because Python call overhead (~0.4 us a call) would otherwise cost more than the
physics: the *signals* (raw wrench, stretch) are read every tick, and everything between them
and the joint velocities is linear in them, so it is one precomposed (6, 13) matrix

    qdot = Q v,   v = [raw sensor wrench (6), position stretch (3), rotation error in port axes (3), 1]

where Q = P [G_w D | diag(K/B)_pos | diag(K/B)_rot R_port | G_w bias], P the DLS inverse,
D and bias the payload-compensated sensor map rotated to base axes. Q depends only on the
arm's configuration (J, sensor and port orientation) and is rebuilt every KINEMATICS_TICKS
ticks (8 ms), or every tick while |qdot| > 1 rad/s or near a singularity: between rebuilds the
configuration moves < 8 mrad, and < 1 mrad at quasi-static speeds. Wrench and stretch feedback
stay at the full 1 kHz.
"""

import math

import mujoco
import numpy as np

from robot_sim.arm import ArmLayout
from robot_sim.errors import SimulationFault
from robot_sim.gains import Gains
from robot_sim.payload import Payload
from robot_sim.pose_math import IDENTITY_QUAT, rotate_world

# Damped least squares: lambda^2 grows from 0 to LAMBDA_MAX^2 as the manipulability
# sqrt(det(J J^T)) falls below MANIPULABILITY_THRESHOLD (Chiaverini's singularity-robust
# inverse). Far from singularities the inverse is exact, so the free-space response stays the
# designed first-order lag. The home pose has manipulability ~0.028, the fully stretched arm 0.
MANIPULABILITY_THRESHOLD = 0.012
LAMBDA_MAX = 0.1
LAMBDA_FLOOR_SQ = 1e-10
# Within this distance of a joint limit [rad], motion toward it is tapered linearly to zero.
JOINT_LIMIT_MARGIN_RAD = 0.15
# Joint acceleration limit [rad/s^2], of the order of a small arm's drives.
JOINT_ACCEL_LIMIT = np.array([40.0, 40.0, 40.0, 80.0, 80.0, 100.0])
# Rebuild Q (Jacobian, DLS inverse, sensor rotation) every N ticks; see the module docstring.
# Every tick instead while near a singularity or while the joints move fast.
KINEMATICS_TICKS = 8
FAST_REFRESH_MANIPULABILITY_RATIO = 2.0  # manipulability / MANIPULABILITY_THRESHOLD
FAST_REFRESH_SPEED = 1.0  # |qdot| [rad/s]


class AdmittanceController:
    """Turns the stretch to the attractor and the sensed wrench into joint-velocity commands."""

    def __init__(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        layout: ArmLayout,
        payload: Payload,
        gains: Gains,
        control_dt: float,
    ) -> None:
        self.model = model
        self.data = data
        self.layout = layout
        self.enabled = False

        # Views into MjData, valid for the data's lifetime.
        self._R_world_ft = data.site_xmat[layout.ft_site].reshape(3, 3)
        self._R_world_port_flat = data.site_xmat[layout.port_site]  # (9,)
        self.p_world_port = data.site_xpos[layout.port_site]  # (3,) [m], read only
        a = layout.ft_sensor_adr
        self._raw_wrench_ft = data.sensordata[a : a + 6]  # force [N], torque [N m], ft axes
        self._qpos = data.qpos[layout.qpos_adr[0] : layout.qpos_adr[0] + 6]
        self._ctrl_pos = data.ctrl[layout.ctrl_pos]  # integrated-velocity servos [rad/s]
        self._ctrl_vel = data.ctrl[layout.ctrl_vel]  # velocity feed-forward servos [rad/s]

        # Attractor pose, base frame. Behaviors write these in place.
        self.p_world_attractor = np.zeros(3)  # [m]
        self.q_world_attractor = IDENTITY_QUAT.copy()  # [w x y z]
        self.q_world_port = IDENTITY_QUAT.copy()

        # The tick's signal vector and its two linear maps.
        self._v = np.zeros(13)
        self._v[12] = 1.0  # bias column: payload weight
        self._v_raw = self._v[0:6]
        self._v_stretch_pos = self._v[6:9]  # [m] base axes
        self._v_rot_err_port = self._v[9:12]  # [rad] port axes
        self._wrench_map = np.zeros((6, 13))  # v -> w_world_env_on_port
        self._qdot_map = np.zeros((6, 13))  # v -> qdot (Q)
        self.w_world_env_on_port = np.zeros(6)  # [N, N m] base axes, torque about the port
        self._w_force = self.w_world_env_on_port[0:3]
        self._w_torque = self.w_world_env_on_port[3:6]
        self.force_norm = 0.0  # |f| [N] this tick
        self.torque_norm = 0.0  # |tau| [N m] this tick

        self._compensation = payload.compensation_matrix()  # (6, 9) ft axes
        self._R_world_ft_flat = data.site_xmat[layout.ft_site]
        self._blockdiag_rr = np.zeros((6, 6))
        self._rr_m = np.zeros((6, 9))
        self._g_ft = np.zeros(3)
        self._twist_map = np.zeros((6, 13))
        self._rot_block = np.zeros((3, 3))
        self._jac_t = np.zeros((6, 6))
        self._dls_inverse = np.zeros((6, 6))  # P, (6 joints, 6 twist components)
        self._chol = np.zeros((6, 6))
        self._chol_diag = self._chol.reshape(36)[::7]
        self._gravity_world = np.array(model.opt.gravity)
        self._jac = np.zeros((6, model.nv))  # rows: linear then angular, world axes
        self._jacp = self._jac[0:3]
        self._jacr = self._jac[3:6]
        self._inv_speed_limit = 1.0 / layout.joint_speed_limit
        self._max_dqdot = JOINT_ACCEL_LIMIT * control_dt  # [rad/s] per tick
        self._lower_soft = (layout.joint_range[:, 0] + 2 * JOINT_LIMIT_MARGIN_RAD).tolist()
        self._upper_soft = (layout.joint_range[:, 1] - 2 * JOINT_LIMIT_MARGIN_RAD).tolist()
        self._near_joint_limit = False
        self._refresh_every_tick = False
        self._ticks = 0
        self._q_tmp = np.zeros(4)
        self.manipulability = 0.0
        self.speed_scale = 1.0  # last uniform scale applied for joint speed limits (<= 1)
        self.set_gains(gains)

    # ----------------------------------------------------------------------------- gains
    def set_gains(self, gains: Gains) -> None:
        """Take new stiffness/damping; the attractor stays, so the virtual wrench may step."""
        self.gains = gains
        self._inv_damping = 1.0 / gains.damping
        self._inv_damping_col = self._inv_damping[:, None].copy()
        k_over_b = gains.stiffness * self._inv_damping
        self._k_over_b_rot_col = k_over_b[3:6, None].copy()
        self._k_over_b_pos_diag = np.diag(k_over_b[0:3])
        self.refresh_kinematics()

    # ---------------------------------------------------------------------- kinematics
    def refresh_kinematics(self) -> None:
        """Rebuild the wrench map and Q from the current configuration; slow checks.

        Written with preallocated arrays: it runs at 1/KINEMATICS_TICKS of the control rate.
        """
        # (MuJoCo's own bad qpos/qvel/qacc checks reset the data; Simulation.step catches that.)
        if not (math.isfinite(mujoco.mju_sum(self._v)) and math.isfinite(mujoco.mju_sum(self._qpos))):
            raise SimulationFault("non-finite wrench, stretch or joint position")
        q = self._qpos.tolist()
        self._near_joint_limit = any(
            not lo < qi < hi for qi, lo, hi in zip(q, self._lower_soft, self._upper_soft, strict=True)
        )

        # Sensor map: w_world = blockdiag(R, R) (M_s raw + M_g R^T g); the weight term is the
        # bias column (v[12] = 1).
        R = self._R_world_ft
        rr = self._blockdiag_rr
        rr[0:3, 0:3] = R
        rr[3:6, 3:6] = R
        np.dot(rr, self._compensation, out=self._rr_m)
        mujoco.mju_mulMatTVec3(self._g_ft, self._R_world_ft_flat, self._gravity_world)
        wmap = self._wrench_map
        wmap[:, 0:6] = self._rr_m[:, 0:6]
        wmap[:, 12] = self._rr_m[:, 6:9] @ self._g_ft

        # DLS inverse P = J^T (J J^T + lambda^2 I)^-1, lambda from the manipulability
        # sqrt(det(J J^T)) = prod(diag(chol(J J^T))). Far from singularities lambda is only the
        # floor, and the factor of J J^T serves as is.
        mujoco.mj_jacSite(self.model, self.data, self._jacp, self._jacr, self.layout.port_site)
        J = self._jac if self._jac.shape[1] == 6 else np.ascontiguousarray(self._jac[:, 0:6])
        chol = self._chol
        np.dot(J, J.T, out=chol)
        mujoco.mju_cholFactor(chol, LAMBDA_FLOOR_SQ)
        self.manipulability = math.prod(self._chol_diag.tolist())
        ratio = self.manipulability / MANIPULABILITY_THRESHOLD
        # Near a singularity, or moving fast, J changes quickly: rebuild Q every tick then.
        self._refresh_every_tick = (
            ratio < FAST_REFRESH_MANIPULABILITY_RATIO or mujoco.mju_norm(self._ctrl_pos) > FAST_REFRESH_SPEED
        )
        if ratio < 1.0:
            np.dot(J, J.T, out=chol)
            self._chol_diag += LAMBDA_MAX**2 * (1.0 - ratio * ratio)
            mujoco.mju_cholFactor(chol, LAMBDA_FLOOR_SQ)
        np.copyto(self._jac_t, J.T)
        P = self._dls_inverse  # row i = (J J^T + lambda^2 I)^-1 (row i of J^T), as J J^T is symmetric
        for i in range(6):
            mujoco.mju_cholSolve(P[i], chol, self._jac_t[i])

        # Q = P [B^-1 wmap + (K/B) stretch columns]; the rotation error arrives in port axes.
        tmap = self._twist_map
        np.multiply(wmap, self._inv_damping_col, out=tmap)  # stretch columns of wmap are 0
        tmap[0:3, 6:9] = self._k_over_b_pos_diag
        np.multiply(self._R_world_port_flat.reshape(3, 3), self._k_over_b_rot_col, out=self._rot_block)
        tmap[3:6, 9:12] = self._rot_block
        np.dot(P, tmap, out=self._qdot_map)

    # ------------------------------------------------------------------------ measuring
    def measure(self) -> None:
        """Compensated wrench and its magnitudes from the current MjData."""
        self._v_raw[:] = self._raw_wrench_ft
        self._wrench_map.dot(self._v, out=self.w_world_env_on_port)
        self.force_norm = mujoco.mju_norm3(self._w_force)
        self.torque_norm = mujoco.mju_norm3(self._w_torque)

    def measure_stretch(self) -> None:
        """Position stretch (base axes) and rotation error (port axes) into the signal vector."""
        mujoco.mju_sub3(self._v_stretch_pos, self.p_world_attractor, self.p_world_port)
        mujoco.mju_mat2Quat(self.q_world_port, self._R_world_port_flat)
        mujoco.mju_subQuat(self._v_rot_err_port, self.q_world_attractor, self.q_world_port)

    def stretch_world(self) -> np.ndarray:
        """(6,) stretch in base axes [m, rad] as of the last measurement."""
        R_port = self._R_world_port_flat.reshape(3, 3)
        return np.concatenate([self._v_stretch_pos, R_port @ self._v_rot_err_port])

    def twist_des(self) -> np.ndarray:
        """(6,) eq. 5's desired twist [m/s, rad/s], base axes, from the last signals."""
        s = self.stretch_world()
        return self._inv_damping * (self.w_world_env_on_port + self.gains.stiffness * s)

    # ---------------------------------------------------------------------------- ticks
    def command(self) -> None:
        """Stretch to the (possibly just moved) attractor, then qdot = Q v to the servos."""
        self._ticks += 1
        if self._refresh_every_tick or self._ticks % KINEMATICS_TICKS == 0:
            self.refresh_kinematics()
        self.measure_stretch()
        if not self.enabled:
            return
        qdot = self._ctrl_pos
        self._qdot_map.dot(self._v, out=qdot)
        # Slow commands far from limits and singularities need no limiting (the common case).
        if mujoco.mju_norm(qdot) > FAST_REFRESH_SPEED or self._refresh_every_tick or self._near_joint_limit:
            self._limit_joint_motion(qdot, previous=self._ctrl_vel)
        else:
            self.speed_scale = 1.0
        self._ctrl_vel[:] = qdot

    def _limit_joint_motion(self, qdot: np.ndarray, previous: np.ndarray) -> None:
        # Speed: one scale for all joints keeps the Cartesian direction.
        peak = float(np.max(np.abs(qdot) * self._inv_speed_limit))
        self.speed_scale = 1.0 if peak <= 1.0 else 1.0 / peak
        if peak > 1.0:
            qdot *= self.speed_scale
        # Acceleration: as a drive would, so the DLS taking over near a singularity (or a
        # sudden attractor jump) decelerates the arm over tens of ms instead of a few.
        np.clip(qdot, previous - self._max_dqdot, previous + self._max_dqdot, out=qdot)
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

    @property
    def qdot_cmd(self) -> np.ndarray:
        """(6,) joint velocities sent to the servos this tick [rad/s]."""
        return self._ctrl_pos

    # ------------------------------------------------------------------ attractor moves
    def enable(self) -> None:
        """Start compliance bumplessly: place the attractor so K s balances the measured wrench.

        In equilibrium w + K s = 0, so s = -K^-1 w; on axes with (near) zero stiffness no
        stretch can hold a force and the attractor is put on the port there.
        """
        self.refresh_kinematics()
        self.measure()
        self.measure_stretch()
        k = self.gains.stiffness
        stretch = np.where(k > 1e-9, -self.w_world_env_on_port / np.maximum(k, 1e-9), 0.0)
        self.place_attractor_from_port(stretch)
        self.measure_stretch()
        self.enabled = True

    def disable(self) -> None:
        """Position hold: the servos keep their last integrated reference."""
        self.enabled = False
        self._ctrl_pos[:] = 0.0
        self._ctrl_vel[:] = 0.0

    def place_attractor_from_port(self, stretch_world: np.ndarray) -> None:
        """Attractor = port (+) stretch: translation and base-axes rotation vector (6,)."""
        mujoco.mju_mat2Quat(self.q_world_port, self._R_world_port_flat)
        mujoco.mju_add3(self.p_world_attractor, self.p_world_port, stretch_world[0:3])
        rotate_world(self.q_world_attractor, self.q_world_port, stretch_world[3:6], 1.0, self._q_tmp)

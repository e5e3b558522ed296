"""Admittance controller with a virtual attractor (paper section 2.1.1, eq. 1-5).

Per control tick:

    w      = wrench of the environment on the port, base axes (sensor, payload removed,
             low-passed for control; the raw one is what behaviors check thresholds on)
    s      = stretch: attractor (-) port; position difference and rotation vector
    t_des  = B^-1 (w + K s)                       (eq. 5, K and B diagonal in the gains' frame)
    qdot   = J^T (J J^T + lambda^2 I)^-1 t_des     (damped least squares)

then joint velocities are held to the joint speed and acceleration limits and tapered near
joint limits, and sent to the joint servos (ctrl = qdot for the integrated-velocity and the
feed-forward servo).

Multi-rate, because Python call overhead (~0.4 us a call) would otherwise cost more than the
physics: the *signals* (raw wrench, stretch) are read every tick, and everything between them
and the joint velocities is linear in them, so it is one precomposed (6, 13) matrix

    qdot = Q v,   v = [filtered sensor wrench (6), position stretch (3), rotation error in port axes (3), 1]

where Q = P [B^-1 D | B^-1 K_pos | B^-1 K_rot R_port | B^-1 bias], P the DLS inverse, D and
bias the payload-compensated sensor map rotated to base axes, and B^-1, B^-1 K the diagonal
gains turned from their frame's axes into base axes (R diag R^T; R = I for `base`, R_port for
`tool`, a task frame's fixed rotation). Q depends only on the arm's configuration (J, sensor
and port orientation) and is rebuilt every KINEMATICS_TICKS ticks (8 ms), or every tick while
|qdot| > 1 rad/s or near a singularity: between rebuilds the configuration moves < 8 mrad, and
< 1 mrad at quasi-static speeds. Wrench and stretch feedback stay at the full 1 kHz.
"""

import math
from enum import StrEnum

import mujoco
import numpy as np

from robot_sim.arm import ArmLayout
from robot_sim.errors import SimulationFault
from robot_sim.gains import Gains
from robot_sim.payload import Payload
from robot_sim.pose_math import IDENTITY_QUAT, rotate_world, turn6

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
# First-order low-pass on the F/T signal the admittance law uses [Hz]. Without it the loop
# limit-cycles in stiff contact at low damping (see limits.py for the measured floors).
# Thresholds are checked on the raw signal: a filter must never hide a breach.
FT_CUTOFF_HZ = 100.0
# Axes with stiffness below this hold no force: the balancing rule puts the attractor on the port.
STIFFNESS_EPS = 1e-9


def _rotated_diagonal(R: np.ndarray, diagonal: np.ndarray, out: np.ndarray, tmp: np.ndarray) -> None:
    """out = R diag(diagonal) R^T (3, 3): a diagonal gain in R's axes, seen in base axes."""
    np.multiply(R, diagonal, out=tmp)
    np.dot(tmp, R.T, out=out)


class Limit(StrEnum):
    """What held the commanded motion back this tick (reported as `limited: <value>`)."""

    SINGULARITY = "singularity"  # the DLS damping is on (manipulability below threshold)
    JOINT_LIMIT = "joint_limit"  # a joint is tapered to a stop near its range's end
    SPEED = "speed"  # a joint hit its datasheet speed: the whole motion was scaled down


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
        ft_cutoff_hz: float | None = FT_CUTOFF_HZ,
    ) -> None:
        """Args:
        model, data: the compiled scene and its state (views into data are kept).
        layout: where the arm is in the model.
        payload: the tool below the sensor, compensated out of the reading.
        gains: stiffness/damping and their frame.
        control_dt: control period [s].
        ft_cutoff_hz: low-pass cutoff on the F/T signal used for control [Hz]; None: unfiltered.
        """
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
        self._v_ft = self._v[0:6]  # low-passed raw sensor reading
        self._v_meas = np.zeros(13)  # [raw reading, zeros, 1]: the unfiltered wrench
        self._v_meas[12] = 1.0
        self._v_meas_raw = self._v_meas[0:6]
        self._ft_delta = np.zeros(6)
        self.ft_cutoff_hz = ft_cutoff_hz
        self._ft_alpha = (
            1.0 if ft_cutoff_hz is None else 1.0 - math.exp(-2 * math.pi * ft_cutoff_hz * control_dt)
        )
        self._v_stretch_pos = self._v[6:9]  # [m] base axes
        self._v_rot_err_port = self._v[9:12]  # [rad] port axes
        self._wrench_map = np.zeros((6, 13))  # v -> w_world_env_on_port
        self._qdot_map = np.zeros((6, 13))  # v -> qdot (Q)
        self.w_world_env_on_port = np.zeros(6)  # [N, N m] base axes, torque about the port, raw
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
        self._R_gains = np.eye(3)  # gains' axes in base axes: I (base) or R_world_port (tool)
        self._tmp33 = np.zeros((3, 3))
        self._inv_b_pos = np.zeros((3, 3))  # B^-1 and B^-1 K blocks in base axes
        self._inv_b_rot = np.zeros((3, 3))
        self._kb_pos = np.zeros((3, 3))
        self._kb_rot = np.zeros((3, 3))
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
        self.limits: tuple[Limit, ...] = ()  # every limit that held the motion back this tick
        # the joints slowed at an end of their range this tick: (index, "lower" | "upper")
        self.joints_held: tuple[tuple[int, str], ...] = ()
        self.set_gains(gains)

    @property
    def limited(self) -> Limit | None:
        """The first limit that held the motion back this tick (telemetry's `limited`), if any."""
        return self.limits[0] if self.limits else None

    # ----------------------------------------------------------------------------- gains
    def change_gains(self, gains: Gains) -> None:
        """Take new stiffness/damping bumplessly: the spring's wrench K s is carried over, the
        attractor placed again so the new K pulls as the old one did (`balance` of it). At rest
        that balances the measured wrench, so a force held in contact stays what it was instead
        of stepping by (K_new - K_old) s: the paper's bumpless transition "also employed when the
        robot was in contact with non-zero forces" (2.3.2). Moving, the spring's pull (B v) is
        kept too, so a change mid-move neither stops nor reverses the arm. The same stiffness in
        the same axes (damping alone, or the same gains) leaves the attractor where it is."""
        same_spring = gains.same_spring_as(self.gains)
        spring_world = self.stiffness_world() @ self.stretch_world()
        self.set_gains(gains)
        if self.enabled and not same_spring:
            self.balance(-spring_world)  # balance(w) gives K s = -w

    def set_gains(self, gains: Gains) -> None:
        """Take new stiffness/damping; the attractor stays, so the virtual wrench may step
        (a start or a twin's sync; a command changes gains with `change_gains`)."""
        self.gains = gains
        self._inv_damping = 1.0 / gains.damping  # (6,) gains' axes
        self._k_over_b = gains.stiffness * self._inv_damping
        self._tool_frame_gains = gains.frame == "tool"
        if not self._tool_frame_gains:
            self._R_gains[:] = gains.fixed_axes_world()
            self._rotate_gains()  # constant in base axes: once here, not per refresh
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

        # Q = P [B^-1 wmap + B^-1 K stretch columns]; the rotation error arrives in port axes.
        R_port = self._R_world_port_flat.reshape(3, 3)
        if self._tool_frame_gains:
            self._R_gains[:] = R_port
            self._rotate_gains()
        tmap = self._twist_map
        np.dot(self._inv_b_pos, wmap[0:3], out=tmap[0:3])  # stretch columns of wmap are 0
        np.dot(self._inv_b_rot, wmap[3:6], out=tmap[3:6])
        tmap[0:3, 6:9] = self._kb_pos
        np.dot(self._kb_rot, R_port, out=self._rot_block)
        tmap[3:6, 9:12] = self._rot_block
        np.dot(P, tmap, out=self._qdot_map)

    def _rotate_gains(self) -> None:
        """B^-1 and B^-1 K blocks in base axes from the diagonals in the gains' axes."""
        self._to_base(self._inv_damping[0:3], self._inv_b_pos)
        self._to_base(self._inv_damping[3:6], self._inv_b_rot)
        self._to_base(self._k_over_b[0:3], self._kb_pos)
        self._to_base(self._k_over_b[3:6], self._kb_rot)

    def _to_base(self, diagonal: np.ndarray, out: np.ndarray) -> None:
        """out = R diag(diagonal) R^T with R the gains' current axes (3, 3)."""
        _rotated_diagonal(self._R_gains, diagonal, out, self._tmp33)

    # ------------------------------------------------------------------------ measuring
    def measure(self) -> None:
        """Raw compensated wrench and its magnitudes; the low-passed reading for control."""
        raw = self._raw_wrench_ft
        self._v_meas_raw[:] = raw
        self._wrench_map.dot(self._v_meas, out=self.w_world_env_on_port)
        self.force_norm = mujoco.mju_norm3(self._w_force)
        self.torque_norm = mujoco.mju_norm3(self._w_torque)
        mujoco.mju_sub(self._ft_delta, raw, self._v_ft)
        mujoco.mju_addToScl(self._v_ft, self._ft_delta, self._ft_alpha)

    def control_wrench(self) -> np.ndarray:
        """(6,) the low-passed compensated wrench the admittance law uses [N, N m], base axes."""
        return self._wrench_map @ self._v  # stretch columns of the wrench map are zero

    def measure_stretch(self) -> None:
        """Position stretch (base axes) and rotation error (port axes) into the signal vector."""
        mujoco.mju_sub3(self._v_stretch_pos, self.p_world_attractor, self.p_world_port)
        mujoco.mju_mat2Quat(self.q_world_port, self._R_world_port_flat)
        mujoco.mju_subQuat(self._v_rot_err_port, self.q_world_attractor, self.q_world_port)

    def stretch_world(self) -> np.ndarray:
        """(6,) stretch in base axes [m, rad] as of the last measurement."""
        R_port = self._R_world_port_flat.reshape(3, 3)
        return np.concatenate([self._v_stretch_pos, R_port @ self._v_rot_err_port])

    def gains_rotation(self) -> np.ndarray:
        """(3, 3) the gains' axes in base axes: I for `base`, the port's rotation for `tool`, a
        task frame's own."""
        if self.gains.frame == "tool":
            return self._R_world_port_flat.reshape(3, 3).copy()
        return self.gains.fixed_axes_world().copy()

    def _diag_world(self, diagonal: np.ndarray) -> np.ndarray:
        """(6, 6) blockdiag(R diag R^T) of a (6,) diagonal in the gains' axes."""
        R, tmp, block = self.gains_rotation(), np.zeros((3, 3)), np.zeros((3, 3))
        out = np.zeros((6, 6))
        for axes in (slice(0, 3), slice(3, 6)):
            _rotated_diagonal(R, diagonal[axes], block, tmp)  # np.dot needs a contiguous out
            out[axes, axes] = block
        return out

    def stiffness_world(self) -> np.ndarray:
        """(6, 6) K in base axes [N/m, N m/rad]."""
        return self._diag_world(self.gains.stiffness)

    def twist_des(self) -> np.ndarray:
        """(6,) eq. 5's desired twist [m/s, rad/s], base axes, from the last signals."""
        return self.twist_for(self.control_wrench())

    def twist_for(self, w_world: np.ndarray) -> np.ndarray:
        """(6,) eq. 5's twist [m/s, rad/s] with `w_world` (6,) as the wrench, from the last
        stretch: how fast a robot with this attractor would move under that measured wrench."""
        s = self.stretch_world()
        return self._diag_world(self._inv_damping) @ (w_world + self.stiffness_world() @ s)

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
            self.limits = self._limit_joint_motion(qdot, previous=self._ctrl_vel)
        else:
            self.speed_scale = 1.0
            self.limits, self.joints_held = (), ()
        self._ctrl_vel[:] = qdot

    def _limit_joint_motion(self, qdot: np.ndarray, previous: np.ndarray) -> tuple[Limit, ...]:
        """Hold qdot to the drives' limits in place; every limit that held the motion back."""
        # Speed: one scale for all joints keeps the Cartesian direction.
        peak = float(np.max(np.abs(qdot) * self._inv_speed_limit))
        self.speed_scale = 1.0 if peak <= 1.0 else 1.0 / peak
        if peak > 1.0:
            qdot *= self.speed_scale
        # Acceleration: as a drive would, so the DLS taking over near a singularity (or a
        # sudden attractor jump) decelerates the arm over tens of ms instead of a few.
        np.clip(qdot, previous - self._max_dqdot, previous + self._max_dqdot, out=qdot)
        self.joints_held = self._taper_at_joint_limits(qdot) if self._near_joint_limit else ()
        return (
            (Limit.SINGULARITY,) * (self.manipulability < MANIPULABILITY_THRESHOLD)
            + (Limit.JOINT_LIMIT,) * bool(self.joints_held)
            + (Limit.SPEED,) * (peak > 1.0)
        )

    def _taper_at_joint_limits(self, qdot: np.ndarray) -> tuple[tuple[int, str], ...]:
        """Slow each joint toward its limit linearly over the last margin: it stops, never hits.

        Returns the joints slowed, each with the end it was slowed toward.
        """
        q = self._qpos
        lo = self.layout.joint_range[:, 0]
        hi = self.layout.joint_range[:, 1]
        vmax = self.layout.joint_speed_limit
        slowed: list[tuple[int, str]] = []
        for i in range(6):
            if qdot[i] > 0.0:
                cap = vmax[i] * max(0.0, min(1.0, (hi[i] - q[i]) / JOINT_LIMIT_MARGIN_RAD))
                if qdot[i] > cap:
                    qdot[i] = cap
                    slowed.append((i, "upper"))
            elif qdot[i] < 0.0:
                cap = vmax[i] * max(0.0, min(1.0, (q[i] - lo[i]) / JOINT_LIMIT_MARGIN_RAD))
                if qdot[i] < -cap:
                    qdot[i] = -cap
                    slowed.append((i, "lower"))
        return tuple(slowed)

    @property
    def qdot_cmd(self) -> np.ndarray:
        """(6,) joint velocities sent to the servos this tick [rad/s]."""
        return self._ctrl_pos

    # ------------------------------------------------------------------ attractor moves
    def enable(self) -> None:
        """Start compliance bumplessly: place the attractor so K s balances the measured wrench."""
        self.refresh_kinematics()
        self.measure()
        self._v_ft[:] = self._raw_wrench_ft  # the filter starts from the reading, not from zero
        self.balance(self.control_wrench())
        self.enabled = True

    def balance(self, w_world: np.ndarray) -> None:
        """Place the attractor so the virtual wrench K s balances `w_world` (6,) [N, N m].

        The one rule behind a bumpless start, STOP and `on_breach: limit`: in equilibrium
        w + K s = 0, so s = -K^-1 w, solved in the gains' axes where K is diagonal. On axes with
        (near) zero stiffness no stretch can hold a force and the attractor goes on the port.
        """
        R = self.gains_rotation()
        k = self.gains.stiffness
        w_gains = turn6(R.T, w_world)
        s_gains = np.where(k > STIFFNESS_EPS, -w_gains / np.maximum(k, STIFFNESS_EPS), 0.0)
        self.place_attractor_from_port(turn6(R, s_gains))
        self.measure_stretch()

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

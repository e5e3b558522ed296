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

The per-tick math is compiled (tick.py); this class keeps what runs once per command.
Multi-rate, because the kinematics cost more than the physics: the *signals* (raw wrench,
stretch) are read every tick, and everything between them and the joint velocities is linear
in them, so it is one precomposed (6, 13) matrix

    qdot = Q v,   v = [filtered sensor wrench (6), position stretch (3), rotation error in port axes (3), 1]

where Q = P [B^-1 D | B^-1 K_pos | B^-1 K_rot R_port | B^-1 bias], P the DLS inverse, D and
bias the payload-compensated sensor map rotated to base axes, and B^-1, B^-1 K the diagonal
gains turned from their frame's axes into base axes (R diag R^T; R = I for `base`, R_port for
`tool`, a task frame's fixed rotation). Q depends only on the arm's configuration (J, sensor
and port orientation) and is rebuilt every KINEMATICS_TICKS ticks (8 ms), or every tick while
|qdot| > 1 rad/s or near a singularity: between rebuilds the configuration moves < 8 mrad, and
< 1 mrad at quasi-static speeds. Wrench and stretch feedback stay at the full 1 kHz.
"""

import ctypes
import math
from enum import StrEnum

import mujoco
import numpy as np

from robot_sim import tick
from robot_sim.arm import ArmLayout
from robot_sim.errors import SimulationFault
from robot_sim.gains import Gains
from robot_sim.payload import Payload
from robot_sim.pose_math import turn6
from robot_sim.tick import LAMBDA_FLOOR_SQ, LAMBDA_MAX, MANIPULABILITY_THRESHOLD  # noqa: F401 (the rule's home)

# Joint acceleration limit [rad/s^2], of the order of a small arm's drives.
JOINT_ACCEL_LIMIT = np.array([40.0, 40.0, 40.0, 80.0, 80.0, 100.0])
# First-order low-pass on the F/T signal the admittance law uses [Hz]. Without it the loop
# limit-cycles in stiff contact at low damping (see limits.py for the measured floors).
# Thresholds are checked on the raw signal: a filter must never hide a breach.
FT_CUTOFF_HZ = 100.0
# Axes with stiffness below this hold no force: the balancing rule puts the attractor on the port.
STIFFNESS_EPS = 1e-9


def _rotated_diagonal(R: np.ndarray, diagonal: np.ndarray) -> np.ndarray:
    """(3, 3) R diag(diagonal) R^T: a diagonal gain in R's axes, seen in base axes (tick.py's rule)."""
    out = np.zeros(9)
    tick.rotated_diagonal(
        np.ascontiguousarray(R, dtype=float).ravel(),
        np.ascontiguousarray(diagonal, dtype=float),
        out,
        np.zeros(9),
    )
    return out.reshape(3, 3)


def time_view(data: mujoco.MjData) -> np.ndarray:
    """(1,) a view of data.time, which the bindings give only as a number: in mjData `time`
    comes right before `energy[2]`, whose view they do give (checked here both ways)."""
    energy = data.energy
    view = np.ctypeslib.as_array((ctypes.c_double * 1).from_address(energy.ctypes.data - 8))
    saved = data.time
    for probe in (1.25, -3.5):
        data.time = probe
        if view[0] != probe:
            raise RuntimeError("this MuJoCo's mjData does not keep `time` right before `energy`")
    data.time = saved
    return view


class Limit(StrEnum):
    """What held the commanded motion back this tick (reported as `limited: <value>`)."""

    SINGULARITY = "singularity"  # the DLS damping is on (manipulability below threshold)
    JOINT_LIMIT = "joint_limit"  # a joint is tapered to a stop near its range's end
    SPEED = "speed"  # a joint hit its datasheet speed: the whole motion was scaled down


_LIMIT_BITS = (
    (tick.LIMIT_SINGULARITY, Limit.SINGULARITY),
    (tick.LIMIT_JOINT_LIMIT, Limit.JOINT_LIMIT),
    (tick.LIMIT_SPEED, Limit.SPEED),
)
JOINT_ENDS = {tick.JOINT_AT_LOWER: "lower", tick.JOINT_AT_UPPER: "upper"}


class AdmittanceController:
    """Turns the stretch to the attractor and the sensed wrench into joint-velocity commands.

    The per-tick math is tick.py's (compiled); this object owns its state buffers, names views
    into them, and keeps the rules that run once per command (gains, balancing, placing)."""

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
        f = self.f = np.zeros(tick.f_size(model.nv))  # tick.py's float state
        i = self.i = np.zeros(tick.I_SIZE, dtype=np.int64)  # and its integer state
        # the MjData arrays the tick reads and writes (tick.py's MjArrays)
        self.mj = (
            data.qpos,
            data.ctrl,
            data.sensordata,
            data.site_xpos,
            data.site_xmat,
            time_view(data),
        )
        i[tick.M_ADDRESS] = model._address
        i[tick.D_ADDRESS] = data._address
        i[tick.NV] = model.nv
        i[tick.PORT_SITE] = layout.port_site
        i[tick.FT_SITE] = layout.ft_site
        i[tick.FT_ADR] = layout.ft_sensor_adr
        i[tick.QPOS_ADR] = layout.qpos_adr[0]

        # Views into MjData, valid for the data's lifetime.
        self._R_world_port_flat = data.site_xmat[layout.port_site]  # (9,)
        self.p_world_port = data.site_xpos[layout.port_site]  # (3,) [m], read only
        a = layout.ft_sensor_adr
        self._raw_wrench_ft = data.sensordata[a : a + 6]  # force [N], torque [N m], ft axes
        self._ctrl_pos = data.ctrl[layout.ctrl_pos]  # integrated-velocity servos [rad/s]
        self._ctrl_vel = data.ctrl[layout.ctrl_vel]  # velocity feed-forward servos [rad/s]

        # Attractor pose, base frame. Behaviors write these in place.
        self.p_world_attractor = f[tick.P_WORLD_ATTRACTOR : tick.P_WORLD_ATTRACTOR + 3]  # [m]
        self.q_world_attractor = f[tick.Q_WORLD_ATTRACTOR : tick.Q_WORLD_ATTRACTOR + 4]  # [w x y z]
        self.q_world_attractor[0] = 1.0
        self.q_world_port = f[tick.Q_WORLD_PORT : tick.Q_WORLD_PORT + 4]
        self.q_world_port[0] = 1.0

        self._v = f[tick.V : tick.V + 13]
        self._v[12] = 1.0  # bias column: payload weight
        self._v_ft = self._v[0:6]  # low-passed raw sensor reading
        f[tick.V_MEAS + 12] = 1.0  # [raw reading, zeros, 1]: the unfiltered wrench
        self.ft_cutoff_hz = ft_cutoff_hz
        f[tick.FT_ALPHA] = (
            1.0 if ft_cutoff_hz is None else 1.0 - math.exp(-2 * math.pi * ft_cutoff_hz * control_dt)
        )
        f[tick.CONTROL_DT] = control_dt
        self._v_stretch_pos = self._v[6:9]  # [m] base axes
        self._v_rot_err_port = self._v[9:12]  # [rad] port axes
        self._wrench_map = f[tick.WRENCH_MAP : tick.WRENCH_MAP + 78].reshape(6, 13)  # v -> wrench
        self.w_world_env_on_port = f[tick.W_WORLD : tick.W_WORLD + 6]  # [N, N m] base axes, raw
        f[tick.COMPENSATION : tick.COMPENSATION + 54] = payload.compensation_matrix().ravel()  # (6, 9)
        f[tick.GRAVITY_WORLD : tick.GRAVITY_WORLD + 3] = model.opt.gravity
        f[tick.INV_SPEED_LIMIT : tick.INV_SPEED_LIMIT + 6] = 1.0 / layout.joint_speed_limit
        f[tick.MAX_DQDOT : tick.MAX_DQDOT + 6] = JOINT_ACCEL_LIMIT * control_dt  # [rad/s] per tick
        f[tick.JOINT_RANGE : tick.JOINT_RANGE + 12] = layout.joint_range.ravel()
        f[tick.SPEED_LIMIT : tick.SPEED_LIMIT + 6] = layout.joint_speed_limit
        f[tick.LOWER_SOFT : tick.LOWER_SOFT + 6] = layout.joint_range[:, 0] + 2 * tick.JOINT_LIMIT_MARGIN_RAD
        f[tick.UPPER_SOFT : tick.UPPER_SOFT + 6] = layout.joint_range[:, 1] - 2 * tick.JOINT_LIMIT_MARGIN_RAD
        self._R_gains = f[tick.R_GAINS : tick.R_GAINS + 9].reshape(3, 3)  # gains' axes in base axes
        self._inv_damping = f[tick.INV_DAMPING : tick.INV_DAMPING + 6]  # (6,) gains' axes
        self._k_over_b = f[tick.K_OVER_B : tick.K_OVER_B + 6]
        f[tick.SPEED_SCALE] = 1.0
        self.set_gains(gains)

    # ------------------------------------------------------------------ state, as numbers
    @property
    def enabled(self) -> bool:
        return bool(self.i[tick.ENABLED])

    @enabled.setter
    def enabled(self, on: bool) -> None:
        self.i[tick.ENABLED] = int(on)

    @property
    def force_norm(self) -> float:
        """|f| [N] this tick."""
        return float(self.f[tick.FORCE_NORM])

    @property
    def torque_norm(self) -> float:
        """|tau| [N m] this tick."""
        return float(self.f[tick.TORQUE_NORM])

    @property
    def manipulability(self) -> float:
        return float(self.f[tick.MANIPULABILITY])

    @property
    def speed_scale(self) -> float:
        """The last uniform scale applied for joint speed limits (<= 1)."""
        return float(self.f[tick.SPEED_SCALE])

    @property
    def limits(self) -> tuple[Limit, ...]:
        """Every limit that held the motion back this tick."""
        bits = int(self.i[tick.LIMITS])
        return tuple(limit for bit, limit in _LIMIT_BITS if bits & bit)

    @property
    def joints_held(self) -> tuple[tuple[int, str], ...]:
        """The joints slowed at an end of their range this tick: (index, "lower" | "upper")."""
        held = self.i[tick.JOINTS_HELD : tick.JOINTS_HELD + 6]
        return tuple((j, JOINT_ENDS[int(end)]) for j, end in enumerate(held) if end != tick.JOINT_FREE)

    @property
    def limited(self) -> Limit | None:
        """The first limit that held the motion back this tick (telemetry's `limited`), if any."""
        limits = self.limits
        return limits[0] if limits else None

    # ------------------------------------------------------------------ the behavior's run
    def start_motion(
        self,
        kind: int,
        t0: float,
        duration: float,
        watchdog: float = math.inf,
        force_threshold: float = math.inf,
        torque_threshold: float = math.inf,
    ) -> None:
        """Begin a behavior's motion block (tick.py): its kind, start time [s], duration and
        watchdog [s], thresholds [N, N m], and the attractor where it is now as its origin."""
        f = self.f
        self.i[tick.MOTION_KIND] = kind
        f[tick.T0] = t0
        f[tick.DURATION] = duration
        f[tick.WATCHDOG] = watchdog
        f[tick.FORCE_THRESHOLD] = force_threshold
        f[tick.TORQUE_THRESHOLD] = torque_threshold
        f[tick.P_FROM : tick.P_FROM + 3] = self.p_world_attractor
        f[tick.Q_FROM : tick.Q_FROM + 4] = self.q_world_attractor

    def start_running(self, monitor_ticks_per_window: int) -> None:
        """From the next tick the loop runs the behavior's motion and keeps its peaks and what
        held it back; a task monitor's window every `monitor_ticks_per_window` ticks (0: none)."""
        f, i = self.f, self.i
        f[tick.PEAK_FORCE] = f[tick.PEAK_TORQUE] = 0.0
        f[tick.HELD_S : tick.HELD_S + 3] = 0.0
        i[tick.HELD_JOINT_END : tick.HELD_JOINT_END + 6] = tick.JOINT_FREE
        i[tick.MONITOR_ACTIVE] = int(monitor_ticks_per_window > 0)
        i[tick.MONITOR_TICKS_PER_WINDOW] = monitor_ticks_per_window
        i[tick.MONITOR_TICKS] = i[tick.MONITOR_STARTED] = 0
        f[tick.MONITOR_FORCE_SUM : tick.MONITOR_FORCE_SUM + 3] = 0.0
        i[tick.RUNNING] = 1

    def stop_running(self) -> None:
        """The behavior ended: the attractor stays where it is."""
        self.i[tick.RUNNING] = 0
        self.i[tick.MOTION_KIND] = tick.MOTION_NONE

    def norm_sums(self) -> tuple[float, float]:
        """(sum of |f| [N], sum of |tau| [N m]) over the ticks run since `set_norm_sums`."""
        return float(self.f[tick.FORCE_NORM_SUM]), float(self.f[tick.TORQUE_NORM_SUM])

    def set_norm_sums(self, force_sum_n: float, torque_sum_nm: float) -> None:
        """Start the sums of |f| and |tau| the loop adds every tick to (a sweep's mean force)."""
        self.f[tick.FORCE_NORM_SUM] = force_sum_n
        self.f[tick.TORQUE_NORM_SUM] = torque_sum_nm

    def held_seconds(self) -> dict[Limit, float]:
        """[s] per limit that held the running behavior's motion back."""
        seconds = self.f[tick.HELD_S : tick.HELD_S + 3]
        return {limit: float(seconds[k]) for k, (_, limit) in enumerate(_LIMIT_BITS) if seconds[k] > 0.0}

    def held_joint_ends(self) -> dict[int, str]:
        """The joints held at an end of their range while the behavior ran, with that end."""
        ends = self.i[tick.HELD_JOINT_END : tick.HELD_JOINT_END + 6]
        return {j: JOINT_ENDS[int(end)] for j, end in enumerate(ends) if end != tick.JOINT_FREE}

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
        self._inv_damping[:] = 1.0 / gains.damping  # (6,) gains' axes
        self._k_over_b[:] = gains.stiffness * self._inv_damping
        self.i[tick.TOOL_FRAME_GAINS] = int(gains.frame == "tool")
        if gains.frame != "tool":
            self._R_gains[:] = gains.fixed_axes_world()
            tick.rotate_gains(self.f)  # constant in base axes: once here, not per refresh
        self.refresh_kinematics()

    # ---------------------------------------------------------------------- kinematics
    def refresh_kinematics(self) -> None:
        """Rebuild the wrench map and Q from the current configuration (tick.py)."""
        # (MuJoCo's own bad qpos/qvel/qacc checks reset the data; the tick sees its time go back.)
        if not tick.refresh_kinematics(self.mj, self.f, self.i):
            raise SimulationFault("non-finite wrench, stretch or joint position")

    # ------------------------------------------------------------------------ measuring
    def measure(self) -> None:
        """Raw compensated wrench and its magnitudes; the low-passed reading for control."""
        tick.measure(self.mj, self.f, self.i)

    def control_wrench(self) -> np.ndarray:
        """(6,) the low-passed compensated wrench the admittance law uses [N, N m], base axes."""
        return self._wrench_map @ self._v  # stretch columns of the wrench map are zero

    def measure_stretch(self) -> None:
        """Position stretch (base axes) and rotation error (port axes) into the signal vector."""
        tick.measure_stretch(self.mj, self.f, self.i)

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
        R = self.gains_rotation()
        out = np.zeros((6, 6))
        for axes in (slice(0, 3), slice(3, 6)):
            out[axes, axes] = _rotated_diagonal(R, diagonal[axes])
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
        if not tick.command(self.mj, self.f, self.i):
            raise SimulationFault("non-finite wrench, stretch or joint position")

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
        self.f[tick.STRETCH_TMP : tick.STRETCH_TMP + 6] = stretch_world
        tick.place_attractor_from_port(self.mj, self.f, self.i, tick.STRETCH_TMP)

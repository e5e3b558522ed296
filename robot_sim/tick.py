# ruff: noqa: N816 (MuJoCo's C names, kept as they are)
"""The 1 kHz path, compiled: the admittance law (controller.py's docstring), the behaviors'
attractor motion and exits, and the physics step, in one loop that runs N ticks per call.

Why compiled: the physics of a tick costs ~7 us; the same arithmetic written as Python calls
cost 20-35 us more (about 0.4 us a call), so every sweep, twin restart and preview paid for the
interpreter. Here a tick is the physics plus about a microsecond.

Why one file: numba's cache (`cache=True`) is keyed on the file that defines a function, not on
what it imports, so the state's layout and every function that reads it live together (a layout
changed elsewhere would leave a stale compiled kernel).

The state is two flat buffers that the Python objects hold views into (`controller.py` names
them): `f` (float64) and `i` (int64), with the offsets below; and the MjData arrays the tick
reads and writes (`MjArrays`). MuJoCo's own C functions (`mj_step`, `mj_jacSite`, the `mju_*`
vector and quaternion helpers) are called by name from libmujoco, the library the `mujoco`
package ships and has already loaded, so the math is MuJoCo's, as in the interpreted loop.

MuJoCo's errors: the bindings turn a fatal MuJoCo error into `mujoco.FatalError`; called from
here, MuJoCo's own handler prints it and ends the process. The only one a step can raise is a
full arena, and the scenes use 0.2 % of theirs at most (a sleeve-on-peg trial: 26 kB of 13.6 MB).

Tick order (as the interpreted loop had it): measure the wrench; keep peaks and what held the
port back; the behavior moves the attractor or ends; the task monitor's window; eq. 5 + DLS
to the servos; mj_step. The loop returns mid-tick (`Stop`) when Python must act before the
servos are commanded: a behavior's exit (a breach's `on_breach` moves the attractor), a
monitor window to judge, or a fault.
"""

import glob
import math
import os
from enum import IntEnum
from typing import Any

import llvmlite.binding
import mujoco
import numpy as np
from numba import njit, types

# ------------------------------------------------------------------------ MuJoCo's C API
# the library the bindings load, beside them (libmujoco.so.X on Linux, libmujoco.X.dylib on macOS)
_LIBRARY = sorted(glob.glob(os.path.join(os.path.dirname(mujoco.__file__), "libmujoco*")))
if not _LIBRARY:
    raise ImportError(f"no libmujoco beside the mujoco package in {os.path.dirname(mujoco.__file__)}")
llvmlite.binding.load_library_permanently(_LIBRARY[0])
_P = types.intp  # a pointer, passed as its address (the same register on 64-bit ABIs)
_I = types.int32
_D = types.float64
_V = types.void


def _c(name: str, signature: Any) -> Any:
    """MuJoCo's C function `name`, callable from compiled code (typed Any: numba checks it)."""
    return types.ExternalFunction(name, signature)


mj_step = _c("mj_step", _V(_P, _P))
mj_jacSite = _c("mj_jacSite", _V(_P, _P, _P, _P, _I))
mju_cholFactor = _c("mju_cholFactor", _I(_P, _I, _D))
mju_cholSolve = _c("mju_cholSolve", _V(_P, _P, _P, _I))
mju_mat2Quat = _c("mju_mat2Quat", _V(_P, _P))
mju_subQuat = _c("mju_subQuat", _V(_P, _P, _P))
mju_mulQuat = _c("mju_mulQuat", _V(_P, _P, _P))
mju_quatIntegrate = _c("mju_quatIntegrate", _V(_P, _P, _D))
mju_mulMatVec = _c("mju_mulMatVec", _V(_P, _P, _P, _I, _I))
mju_mulMatTVec3 = _c("mju_mulMatTVec3", _V(_P, _P, _P))
mju_mulMatMat = _c("mju_mulMatMat", _V(_P, _P, _P, _I, _I, _I))
mju_mulMatMatT = _c("mju_mulMatMatT", _V(_P, _P, _P, _I, _I, _I))
mju_norm = _c("mju_norm", _D(_P, _I))
mju_norm3 = _c("mju_norm3", _D(_P))
mju_dist3 = _c("mju_dist3", _D(_P, _P))
mju_sum = _c("mju_sum", _D(_P, _I))
mju_sub = _c("mju_sub", _V(_P, _P, _P, _I))
mju_sub3 = _c("mju_sub3", _V(_P, _P, _P))
mju_add3 = _c("mju_add3", _V(_P, _P, _P))
mju_addTo3 = _c("mju_addTo3", _V(_P, _P))
mju_addToScl = _c("mju_addToScl", _V(_P, _P, _D, _I))
mju_addToScl3 = _c("mju_addToScl3", _V(_P, _P, _D))
mju_addScl3 = _c("mju_addScl3", _V(_P, _P, _P, _D))
mju_scl3 = _c("mju_scl3", _V(_P, _P, _D))

# ---------------------------------------------------------------------- the controller
# Damped least squares: lambda^2 grows from 0 to LAMBDA_MAX^2 as the manipulability
# sqrt(det(J J^T)) falls below MANIPULABILITY_THRESHOLD (Chiaverini's singularity-robust
# inverse). Far from singularities the inverse is exact, so the free-space response stays the
# designed first-order lag. The home pose has manipulability ~0.028, the fully stretched arm 0.
MANIPULABILITY_THRESHOLD = 0.012
LAMBDA_MAX = 0.1
LAMBDA_FLOOR_SQ = 1e-10
# Within this distance of a joint limit [rad], motion toward it is tapered linearly to zero.
JOINT_LIMIT_MARGIN_RAD = 0.15
# Rebuild Q (Jacobian, DLS inverse, sensor rotation) every N ticks (controller.py's docstring);
# every tick instead while near a singularity or while the joints move fast.
KINEMATICS_TICKS = 8
FAST_REFRESH_MANIPULABILITY_RATIO = 2.0  # manipulability / MANIPULABILITY_THRESHOLD
FAST_REFRESH_SPEED = 1.0  # |qdot| [rad/s]
TRAVEL_TOLERANCE_M = 0.001  # a dither's progress counts as reached this close [m]

# What held the motion back this tick: bits of i[LIMITS], in the order telemetry names them.
LIMIT_SINGULARITY = 1
LIMIT_JOINT_LIMIT = 2
LIMIT_SPEED = 4
JOINT_FREE, JOINT_AT_LOWER, JOINT_AT_UPPER = 0, 1, 2  # i[JOINTS_HELD + j]

# Behaviors the loop runs (i[MOTION_KIND]); each fills the motion block at its start.
MOTION_NONE, MOTION_PTWL, MOTION_DITHER, MOTION_RWE, MOTION_GRIPPER = 0, 1, 2, 3, 4
DITHER_TORSIONAL, DITHER_TRANSLATIONAL = 0, 1


class Stop(IntEnum):
    """Why the loop returned (its return value is the ticks it ran; i[STOP] says why)."""

    RAN = 0  # all the ticks asked for
    GOAL_REACHED = 1
    WRENCH_BREACH = 2
    TIMEOUT = 3
    COMPLETED = 4
    DURATION_ENDED = 5  # an RWE's time is up: Python reads whether it relieved
    MONITOR_WINDOW = 6  # a task-monitor window is full: Python judges it
    NON_FINITE = 7  # a non-finite wrench, stretch or joint position
    UNSTABLE = 8  # MuJoCo reset the data (bad qpos, qvel or qacc)


class _Offsets:
    def __init__(self) -> None:
        self.size = 0

    def take(self, n: int) -> int:
        start = self.size
        self.size += n
        return start


_f = _Offsets()
# the tick's signal vector v = [low-passed sensor wrench (6), position stretch (3), rotation
# error in port axes (3), 1] and the same with the raw reading and no stretch
V = _f.take(13)
V_MEAS = _f.take(13)
WRENCH_MAP = _f.take(6 * 13)  # v -> wrench of the environment on the port, base axes
QDOT_MAP = _f.take(6 * 13)  # v -> qdot (Q)
W_WORLD = _f.take(6)  # [N, N m] raw compensated wrench, base axes, torque about the port
P_WORLD_ATTRACTOR = _f.take(3)  # [m]
Q_WORLD_ATTRACTOR = _f.take(4)  # [w x y z]
Q_WORLD_PORT = _f.take(4)
COMPENSATION = _f.take(6 * 9)  # payload map, ft axes (payload.py)
GRAVITY_WORLD = _f.take(3)
INV_SPEED_LIMIT = _f.take(6)  # [s/rad]
MAX_DQDOT = _f.take(6)  # [rad/s] per tick
JOINT_RANGE = _f.take(12)  # (6, 2) [rad]
SPEED_LIMIT = _f.take(6)  # [rad/s]
LOWER_SOFT = _f.take(6)  # [rad] below these (or above UPPER_SOFT) the joint-limit checks run
UPPER_SOFT = _f.take(6)
R_GAINS = _f.take(9)  # the gains' axes in base axes
INV_DAMPING = _f.take(6)  # B^-1 diagonal, gains' axes
K_OVER_B = _f.take(6)  # B^-1 K diagonal, gains' axes
INV_B_POS = _f.take(9)  # B^-1 and B^-1 K blocks in base axes
INV_B_ROT = _f.take(9)
KB_POS = _f.take(9)
KB_ROT = _f.take(9)
CHOL = _f.take(36)
DLS_INVERSE = _f.take(36)  # P (6 joints, 6 twist components)
JAC_SQUARE = _f.take(36)  # the arm's 6 columns of the port Jacobian
JAC_T = _f.take(36)
RR_M = _f.take(6 * 9)
BLOCKDIAG_RR = _f.take(36)
TWIST_MAP = _f.take(6 * 13)
ROT_BLOCK = _f.take(9)
TMP33 = _f.take(9)
G_FT = _f.take(3)
Q_TMP = _f.take(4)
V_TMP = _f.take(3)
FT_DELTA = _f.take(6)
STRETCH_TMP = _f.take(6)
FT_ALPHA = _f.take(1)  # the F/T low-pass's gain per tick
FORCE_NORM = _f.take(1)  # [N] |f| this tick
TORQUE_NORM = _f.take(1)  # [N m] |tau| this tick
MANIPULABILITY = _f.take(1)
SPEED_SCALE = _f.take(1)  # last uniform scale applied for joint speed limits (<= 1)
CONTROL_DT = _f.take(1)  # [s]
# the running behavior: peaks, time held back, sums for a sweep's mean force
PEAK_FORCE = _f.take(1)
PEAK_TORQUE = _f.take(1)
HELD_S = _f.take(3)  # [s] per limit bit (singularity, joint limit, speed)
FORCE_NORM_SUM = _f.take(1)  # [N] over every tick run (a sweep's mean force)
TORQUE_NORM_SUM = _f.take(1)
# the motion block: what each behavior's start fills (behaviors/*.py)
T0 = _f.take(1)  # [s] sim time at its start
DURATION = _f.take(1)  # [s]
WATCHDOG = _f.take(1)  # [s]
FORCE_THRESHOLD = _f.take(1)  # [N]
TORQUE_THRESHOLD = _f.take(1)  # [N m]
POSITION_TOLERANCE = _f.take(1)  # [m]
ORIENTATION_TOLERANCE = _f.take(1)  # [rad]
P_FROM = _f.take(3)  # attractor at start [m]
Q_FROM = _f.take(4)
DP_WORLD = _f.take(3)  # PTWL: attractor travel [m], base axes
ROTVEC_WORLD = _f.take(3)  # PTWL: attractor rotation [rad], base axes
P_GOAL = _f.take(3)  # PTWL: goal [m]
Q_GOAL = _f.take(4)
AXIS_WORLD = _f.take(3)  # Dither: unit axis, base axes
E1 = _f.take(3)  # Dither: completing the axis to a frame
E2 = _f.take(3)
P_PORT_START = _f.take(3)  # Dither: port at start [m]
SIGN = _f.take(1)  # Dither: +1 push, -1 pull
ENDS_AT = _f.take(1)  # Dither: progress it ends on [m]
TRAVEL = _f.take(1)  # Dither: [m]
AMPLITUDE = _f.take(1)  # Dither: [rad] torsional, [m] translational
FREQUENCY = _f.take(1)  # Dither: [Hz]
WIGGLE = _f.take(3)
KEPT_STRETCH = _f.take(6)  # RWE: stretch kept on the axes it does not relieve, base axes
# the task monitor's window (task_monitor.py judges it)
MONITOR_FORCE_SUM = _f.take(3)  # [N]
MONITOR_P_START = _f.take(3)  # [m] port at the window's start
JACOBIAN = _f.take(0)  # (6, nv): jacp then jacr, the model's own width; the buffer ends here
F_SIZE_BEFORE_JACOBIAN = _f.size

_i = _Offsets()
M_ADDRESS = _i.take(1)  # the MjModel and MjData, as addresses
D_ADDRESS = _i.take(1)
NV = _i.take(1)
PORT_SITE = _i.take(1)
FT_SITE = _i.take(1)
FT_ADR = _i.take(1)  # sensordata[adr:adr+6]: force then torque, ft axes
QPOS_ADR = _i.take(1)  # the arm's six joints from here in qpos
TICKS = _i.take(1)
ENABLED = _i.take(1)
REFRESH_EVERY_TICK = _i.take(1)
NEAR_JOINT_LIMIT = _i.take(1)
TOOL_FRAME_GAINS = _i.take(1)
LIMITS = _i.take(1)  # LIMIT_* bits this tick
JOINTS_HELD = _i.take(6)  # JOINT_* this tick
RUNNING = _i.take(1)  # a behavior runs: peaks, held-back time and its motion are kept
HELD_JOINT_END = _i.take(6)  # JOINT_* last held while it ran
MOTION_KIND = _i.take(1)
ROTATES = _i.take(1)  # PTWL: the attractor turns
ARRIVED = _i.take(1)  # PTWL: the attractor sits on the goal
DITHER_MODE = _i.take(1)
MONITOR_ACTIVE = _i.take(1)
MONITOR_TICKS = _i.take(1)  # ticks summed in this window
MONITOR_TICKS_PER_WINDOW = _i.take(1)
MONITOR_STARTED = _i.take(1)  # the window's start position is set
STOP = _i.take(1)  # a Stop code
MID_TICK = _i.take(1)  # 1: the loop returned before commanding this tick's servos
I_SIZE = _i.size


def f_size(nv: int) -> int:
    """The float buffer's length for a model with `nv` dofs."""
    return F_SIZE_BEFORE_JACOBIAN + 6 * nv


@njit(cache=True, nogil=True)
def _a(f: np.ndarray, offset: int) -> int:
    """The address of f[offset] (MuJoCo's functions take pointers)."""
    return f.ctypes.data + 8 * offset


# MjArrays: (qpos, ctrl, sensordata, site_xpos (nsite, 3), site_xmat (nsite, 9), time (1,)),
# views into one MjData (controller.py builds it). The arm's servos are ctrl[0:6] (position)
# and ctrl[6:12] (velocity), its joints the first six dofs: ArmLayout.from_model checks both.


# The pose rules shared with Python (pose_math.py, controller.py re-use these): on contiguous
# float64 vectors, typed up front so that no other layout can reach the pointers.
_VEC = "float64[::1]"


@njit(f"void({_VEC}, {_VEC}, {_VEC}, {_VEC})", cache=True, nogil=True)
def rotated_diagonal(R: np.ndarray, diagonal: np.ndarray, out: np.ndarray, tmp: np.ndarray) -> None:
    """out (9,) = R diag(diagonal) R^T, R (9,) row-major: a diagonal gain in R's axes, in base axes."""
    for r in range(3):
        for c in range(3):
            tmp[3 * r + c] = R[3 * r + c] * diagonal[c]
    mju_mulMatMatT(out.ctypes.data, tmp.ctypes.data, R.ctypes.data, 3, 3, 3)


@njit(f"void({_VEC}, {_VEC}, {_VEC}, float64, {_VEC})", cache=True, nogil=True)
def rotate_world(
    q_out: np.ndarray, q_in: np.ndarray, rotvec_world: np.ndarray, scale: float, q_tmp: np.ndarray
) -> None:
    """q_out = exp(scale * rotvec_world) * q_in: rotate q_in about base axes (no allocation)."""
    q_tmp[0] = 1.0
    q_tmp[1:4] = 0.0
    mju_quatIntegrate(q_tmp.ctypes.data, rotvec_world.ctypes.data, scale)
    mju_mulQuat(q_out.ctypes.data, q_tmp.ctypes.data, q_in.ctypes.data)


@njit(f"float64({_VEC}, {_VEC}, {_VEC})", cache=True, nogil=True)
def angle_between(q_a: np.ndarray, q_b: np.ndarray, tmp3: np.ndarray) -> float:
    """Rotation angle [rad] taking q_b to q_a."""
    mju_subQuat(tmp3.ctypes.data, q_a.ctypes.data, q_b.ctypes.data)
    return mju_norm3(tmp3.ctypes.data)


@njit(cache=True, nogil=True)
def _v(f: np.ndarray, offset: int, n: int) -> np.ndarray:
    """f[offset:offset + n], a contiguous view."""
    return f[offset : offset + n]


@njit(cache=True, nogil=True)
def rotate_gains(f: np.ndarray) -> None:
    """B^-1 and B^-1 K blocks in base axes: R diag(d) R^T from the diagonals in the gains' axes."""
    R, tmp = _v(f, R_GAINS, 9), _v(f, TMP33, 9)
    rotated_diagonal(R, _v(f, INV_DAMPING, 3), _v(f, INV_B_POS, 9), tmp)
    rotated_diagonal(R, _v(f, INV_DAMPING + 3, 3), _v(f, INV_B_ROT, 9), tmp)
    rotated_diagonal(R, _v(f, K_OVER_B, 3), _v(f, KB_POS, 9), tmp)
    rotated_diagonal(R, _v(f, K_OVER_B + 3, 3), _v(f, KB_ROT, 9), tmp)


@njit(cache=True, nogil=True)
def refresh_kinematics(mj: tuple, f: np.ndarray, i: np.ndarray) -> bool:
    """Rebuild the wrench map and Q from the current configuration; False: a non-finite signal."""
    qpos, ctrl, _sensordata, _site_xpos, site_xmat, _time = mj
    q0 = i[QPOS_ADR]
    if not (math.isfinite(mju_sum(_a(f, V), 13)) and math.isfinite(mju_sum(qpos.ctypes.data + 8 * q0, 6))):
        return False
    near = 0
    for j in range(6):
        qj = qpos[q0 + j]
        if not f[LOWER_SOFT + j] < qj < f[UPPER_SOFT + j]:
            near = 1
    i[NEAR_JOINT_LIMIT] = near

    # Sensor map: w_world = blockdiag(R, R) (M_s raw + M_g R^T g); the weight term is the bias
    # column (v[12] = 1).
    R_ft = site_xmat[i[FT_SITE]]
    for r in range(3):
        for c in range(3):
            f[BLOCKDIAG_RR + 6 * r + c] = R_ft[3 * r + c]
            f[BLOCKDIAG_RR + 6 * (r + 3) + c + 3] = R_ft[3 * r + c]
    mju_mulMatMat(_a(f, RR_M), _a(f, BLOCKDIAG_RR), _a(f, COMPENSATION), 6, 6, 9)
    mju_mulMatTVec3(_a(f, G_FT), R_ft.ctypes.data, _a(f, GRAVITY_WORLD))
    for r in range(6):
        for c in range(6):
            f[WRENCH_MAP + 13 * r + c] = f[RR_M + 9 * r + c]
        m = RR_M + 9 * r + 6  # the row's weight columns
        f[WRENCH_MAP + 13 * r + 12] = f[m] * f[G_FT] + f[m + 1] * f[G_FT + 1] + f[m + 2] * f[G_FT + 2]

    # DLS inverse P = J^T (J J^T + lambda^2 I)^-1, lambda from the manipulability
    # sqrt(det(J J^T)) = prod(diag(chol(J J^T))).
    nv = i[NV]
    mj_jacSite(i[M_ADDRESS], i[D_ADDRESS], _a(f, JACOBIAN), _a(f, JACOBIAN + 3 * nv), i[PORT_SITE])
    for r in range(6):
        for c in range(6):
            f[JAC_SQUARE + 6 * r + c] = f[JACOBIAN + nv * r + c]
            f[JAC_T + 6 * c + r] = f[JACOBIAN + nv * r + c]
    mju_mulMatMatT(_a(f, CHOL), _a(f, JAC_SQUARE), _a(f, JAC_SQUARE), 6, 6, 6)
    mju_cholFactor(_a(f, CHOL), 6, LAMBDA_FLOOR_SQ)
    manipulability = 1.0
    for j in range(6):
        manipulability *= f[CHOL + 7 * j]
    f[MANIPULABILITY] = manipulability
    ratio = manipulability / MANIPULABILITY_THRESHOLD
    # Near a singularity, or moving fast, J changes quickly: rebuild Q every tick then.
    fast = ratio < FAST_REFRESH_MANIPULABILITY_RATIO or mju_norm(ctrl.ctypes.data, 6) > FAST_REFRESH_SPEED
    i[REFRESH_EVERY_TICK] = 1 if fast else 0
    if ratio < 1.0:
        mju_mulMatMatT(_a(f, CHOL), _a(f, JAC_SQUARE), _a(f, JAC_SQUARE), 6, 6, 6)
        for j in range(6):
            f[CHOL + 7 * j] += LAMBDA_MAX**2 * (1.0 - ratio * ratio)
        mju_cholFactor(_a(f, CHOL), 6, LAMBDA_FLOOR_SQ)
    for j in range(6):  # row j = (J J^T + lambda^2 I)^-1 (row j of J^T), as J J^T is symmetric
        mju_cholSolve(_a(f, DLS_INVERSE + 6 * j), _a(f, CHOL), _a(f, JAC_T + 6 * j), 6)

    # Q = P [B^-1 wmap + B^-1 K stretch columns]; the rotation error arrives in port axes.
    R_port = site_xmat[i[PORT_SITE]]
    if i[TOOL_FRAME_GAINS]:
        f[R_GAINS : R_GAINS + 9] = R_port
        rotate_gains(f)
    mju_mulMatMat(_a(f, TWIST_MAP), _a(f, INV_B_POS), _a(f, WRENCH_MAP), 3, 3, 13)
    mju_mulMatMat(_a(f, TWIST_MAP + 39), _a(f, INV_B_ROT), _a(f, WRENCH_MAP + 39), 3, 3, 13)
    mju_mulMatMat(_a(f, ROT_BLOCK), _a(f, KB_ROT), R_port.ctypes.data, 3, 3, 3)
    for r in range(3):
        for c in range(3):
            f[TWIST_MAP + 13 * r + 6 + c] = f[KB_POS + 3 * r + c]
            f[TWIST_MAP + 13 * (r + 3) + 9 + c] = f[ROT_BLOCK + 3 * r + c]
    mju_mulMatMat(_a(f, QDOT_MAP), _a(f, DLS_INVERSE), _a(f, TWIST_MAP), 6, 6, 13)
    return True


@njit(cache=True, nogil=True)
def measure(mj: tuple, f: np.ndarray, i: np.ndarray) -> None:
    """Raw compensated wrench and its magnitudes; the low-passed reading for control."""
    sensordata = mj[2]
    raw = sensordata.ctypes.data + 8 * i[FT_ADR]
    a = i[FT_ADR]
    for j in range(6):
        f[V_MEAS + j] = sensordata[a + j]
    mju_mulMatVec(_a(f, W_WORLD), _a(f, WRENCH_MAP), _a(f, V_MEAS), 6, 13)
    f[FORCE_NORM] = mju_norm3(_a(f, W_WORLD))
    f[TORQUE_NORM] = mju_norm3(_a(f, W_WORLD + 3))
    mju_sub(_a(f, FT_DELTA), raw, _a(f, V), 6)
    mju_addToScl(_a(f, V), _a(f, FT_DELTA), f[FT_ALPHA], 6)


@njit(cache=True, nogil=True)
def measure_stretch(mj: tuple, f: np.ndarray, i: np.ndarray) -> None:
    """Position stretch (base axes) and rotation error (port axes) into the signal vector."""
    site_xpos, site_xmat = mj[3], mj[4]
    port = i[PORT_SITE]
    mju_sub3(_a(f, V + 6), _a(f, P_WORLD_ATTRACTOR), site_xpos[port].ctypes.data)
    mju_mat2Quat(_a(f, Q_WORLD_PORT), site_xmat[port].ctypes.data)
    mju_subQuat(_a(f, V + 9), _a(f, Q_WORLD_ATTRACTOR), _a(f, Q_WORLD_PORT))


@njit(cache=True, nogil=True)
def place_attractor_from_port(mj: tuple, f: np.ndarray, i: np.ndarray, stretch: int) -> None:
    """Attractor = port (+) f[stretch:stretch+6]: translation and base-axes rotation vector."""
    site_xpos, site_xmat = mj[3], mj[4]
    port = i[PORT_SITE]
    mju_mat2Quat(_a(f, Q_WORLD_PORT), site_xmat[port].ctypes.data)
    mju_add3(_a(f, P_WORLD_ATTRACTOR), site_xpos[port].ctypes.data, _a(f, stretch))
    rotate_world(
        _v(f, Q_WORLD_ATTRACTOR, 4), _v(f, Q_WORLD_PORT, 4), _v(f, stretch + 3, 3), 1.0, _v(f, Q_TMP, 4)
    )


@njit(cache=True, nogil=True)
def command(mj: tuple, f: np.ndarray, i: np.ndarray) -> bool:
    """Stretch to the (possibly just moved) attractor, then qdot = Q v to the servos; False: a
    non-finite signal."""
    qpos, ctrl = mj[0], mj[1]
    i[TICKS] += 1
    refresh = i[REFRESH_EVERY_TICK] or i[TICKS] % KINEMATICS_TICKS == 0
    if refresh and not refresh_kinematics(mj, f, i):
        return False
    measure_stretch(mj, f, i)
    if not i[ENABLED]:
        return True
    mju_mulMatVec(ctrl.ctypes.data, _a(f, QDOT_MAP), _a(f, V), 6, 13)
    # Slow commands far from limits and singularities need no limiting (the common case).
    if mju_norm(ctrl.ctypes.data, 6) > FAST_REFRESH_SPEED or i[REFRESH_EVERY_TICK] or i[NEAR_JOINT_LIMIT]:
        _limit_joint_motion(qpos, ctrl, f, i)
    else:
        f[SPEED_SCALE] = 1.0
        i[LIMITS] = 0
        i[JOINTS_HELD : JOINTS_HELD + 6] = JOINT_FREE
    ctrl[6:12] = ctrl[0:6]
    return True


@njit(cache=True, nogil=True)
def _limit_joint_motion(qpos: np.ndarray, ctrl: np.ndarray, f: np.ndarray, i: np.ndarray) -> None:
    """Hold qdot (ctrl[0:6]) to the drives' limits in place; i[LIMITS]: every limit that held
    the motion back. ctrl[6:12] still holds last tick's command."""
    # Speed: one scale for all joints keeps the Cartesian direction.
    peak = 0.0
    for j in range(6):
        peak = max(peak, abs(ctrl[j]) * f[INV_SPEED_LIMIT + j])
    f[SPEED_SCALE] = 1.0 if peak <= 1.0 else 1.0 / peak
    limits = LIMIT_SPEED if peak > 1.0 else 0
    for j in range(6):
        if peak > 1.0:
            ctrl[j] *= f[SPEED_SCALE]
        # Acceleration: as a drive would, so the DLS taking over near a singularity (or a
        # sudden attractor jump) decelerates the arm over tens of ms instead of a few.
        previous, step = ctrl[6 + j], f[MAX_DQDOT + j]
        ctrl[j] = min(max(ctrl[j], previous - step), previous + step)
        i[JOINTS_HELD + j] = JOINT_FREE
    if i[NEAR_JOINT_LIMIT]:
        # Slow each joint toward its limit linearly over the last margin: it stops, never hits.
        q0 = i[QPOS_ADR]
        for j in range(6):
            vmax, q = f[SPEED_LIMIT + j], qpos[q0 + j]
            if ctrl[j] > 0.0:
                cap = vmax * max(0.0, min(1.0, (f[JOINT_RANGE + 2 * j + 1] - q) / JOINT_LIMIT_MARGIN_RAD))
                if ctrl[j] > cap:
                    ctrl[j] = cap
                    i[JOINTS_HELD + j] = JOINT_AT_UPPER
                    limits |= LIMIT_JOINT_LIMIT
            elif ctrl[j] < 0.0:
                cap = vmax * max(0.0, min(1.0, (q - f[JOINT_RANGE + 2 * j]) / JOINT_LIMIT_MARGIN_RAD))
                if ctrl[j] < -cap:
                    ctrl[j] = -cap
                    i[JOINTS_HELD + j] = JOINT_AT_LOWER
                    limits |= LIMIT_JOINT_LIMIT
    if f[MANIPULABILITY] < MANIPULABILITY_THRESHOLD:
        limits |= LIMIT_SINGULARITY
    i[LIMITS] = limits


# ----------------------------------------------------------------------- the behaviors
@njit(cache=True, nogil=True)
def _wrench_breached(f: np.ndarray) -> bool:
    """|f| or |tau| on the port over its threshold this tick (checked before success)."""
    return f[FORCE_NORM] > f[FORCE_THRESHOLD] or f[TORQUE_NORM] > f[TORQUE_THRESHOLD]


@njit(cache=True, nogil=True)
def _dither_progress(mj: tuple, f: np.ndarray, i: np.ndarray) -> float:
    """How far the port has gone along a dither's axis in the commanded direction [m]."""
    p_port = mj[3][i[PORT_SITE]]
    moved = 0.0
    for j in range(3):
        moved += (p_port[j] - f[P_PORT_START + j]) * f[AXIS_WORLD + j]
    return f[SIGN] * moved


@njit(cache=True, nogil=True)
def _ptwl(mj: tuple, f: np.ndarray, i: np.ndarray, elapsed: float) -> int:
    """PTWL (behaviors/ptwl.py): breach, goal, watchdog; else the attractor's straight travel."""
    if _wrench_breached(f):
        return Stop.WRENCH_BREACH
    p_port = mj[3][i[PORT_SITE]].ctypes.data
    if (
        mju_dist3(_a(f, P_GOAL), p_port) <= f[POSITION_TOLERANCE]
        and angle_between(_v(f, Q_GOAL, 4), _v(f, Q_WORLD_PORT, 4), _v(f, V_TMP, 3))
        <= f[ORIENTATION_TOLERANCE]
    ):
        return Stop.GOAL_REACHED
    if elapsed >= f[WATCHDOG]:
        return Stop.TIMEOUT
    if i[ARRIVED]:
        return Stop.RAN  # the attractor sits on the goal; nothing to move
    alpha = elapsed / f[DURATION]
    if alpha >= 1.0:
        alpha = 1.0
        i[ARRIVED] = 1
    mju_addScl3(_a(f, P_WORLD_ATTRACTOR), _a(f, P_FROM), _a(f, DP_WORLD), alpha)
    if i[ROTATES]:
        rotate_world(
            _v(f, Q_WORLD_ATTRACTOR, 4), _v(f, Q_FROM, 4), _v(f, ROTVEC_WORLD, 3), alpha, _v(f, Q_TMP, 4)
        )
    return Stop.RAN


@njit(cache=True, nogil=True)
def _dither(mj: tuple, f: np.ndarray, i: np.ndarray, elapsed: float) -> int:
    """Dither (behaviors/dither.py): breach, progress, watchdog; else the advancing wiggle."""
    if _wrench_breached(f):
        return Stop.WRENCH_BREACH
    if _dither_progress(mj, f, i) >= f[ENDS_AT] - TRAVEL_TOLERANCE_M:
        return Stop.GOAL_REACHED
    if elapsed >= f[WATCHDOG]:
        return Stop.TIMEOUT
    frequency = f[FREQUENCY]
    advance = f[SIGN] * f[TRAVEL] * min(1.0, elapsed / f[DURATION])
    amplitude = f[AMPLITUDE] * min(1.0, elapsed * frequency)
    phase = 2.0 * math.pi * frequency * elapsed
    mju_addScl3(_a(f, P_WORLD_ATTRACTOR), _a(f, P_FROM), _a(f, AXIS_WORLD), advance)
    if i[DITHER_MODE] == DITHER_TORSIONAL:
        mju_scl3(_a(f, WIGGLE), _a(f, AXIS_WORLD), amplitude * math.sin(phase))
        rotate_world(_v(f, Q_WORLD_ATTRACTOR, 4), _v(f, Q_FROM, 4), _v(f, WIGGLE, 3), 1.0, _v(f, Q_TMP, 4))
    else:
        mju_scl3(_a(f, WIGGLE), _a(f, E1), amplitude * math.cos(phase))
        mju_addToScl3(_a(f, WIGGLE), _a(f, E2), amplitude * math.sin(phase))
        mju_addTo3(_a(f, P_WORLD_ATTRACTOR), _a(f, WIGGLE))
        f[Q_WORLD_ATTRACTOR : Q_WORLD_ATTRACTOR + 4] = f[Q_FROM : Q_FROM + 4]
    return Stop.RAN


@njit(cache=True, nogil=True)
def _move_attractor(mj: tuple, f: np.ndarray, i: np.ndarray, t: float) -> int:
    """The running behavior's tick at sim time t [s]: a Stop code (RAN: it goes on)."""
    kind = i[MOTION_KIND]
    elapsed = t - f[T0]
    if kind == MOTION_PTWL:
        return _ptwl(mj, f, i, elapsed)
    if kind == MOTION_DITHER:
        return _dither(mj, f, i, elapsed)
    if kind == MOTION_RWE:
        # RWE (behaviors/rwe.py): the attractor back on the port along the relieved axes
        place_attractor_from_port(mj, f, i, KEPT_STRETCH)
        return Stop.RAN if elapsed < f[DURATION] else Stop.DURATION_ENDED
    if kind == MOTION_GRIPPER:
        return Stop.COMPLETED if elapsed >= f[DURATION] else Stop.RAN
    return Stop.RAN


# ----------------------------------------------------------------------------- the loop
@njit(cache=True, nogil=True)
def _head(mj: tuple, f: np.ndarray, i: np.ndarray) -> int:
    """A tick up to the servos: measure, peaks, held-back time, the behavior, the monitor."""
    measure(mj, f, i)
    f[FORCE_NORM_SUM] += f[FORCE_NORM]
    f[TORQUE_NORM_SUM] += f[TORQUE_NORM]
    if not i[RUNNING]:
        return Stop.RAN
    f[PEAK_FORCE] = max(f[PEAK_FORCE], f[FORCE_NORM])
    f[PEAK_TORQUE] = max(f[PEAK_TORQUE], f[TORQUE_NORM])
    limits = i[LIMITS]  # what held last tick's command back
    if limits:
        for bit in range(3):
            if limits & (1 << bit):
                f[HELD_S + bit] += f[CONTROL_DT]
        for j in range(6):
            if i[JOINTS_HELD + j] != JOINT_FREE:
                i[HELD_JOINT_END + j] = i[JOINTS_HELD + j]
    stop = _move_attractor(mj, f, i, mj[5][0])  # its own exits first: a breach before all
    if stop != Stop.RAN or not i[MONITOR_ACTIVE]:
        return stop
    p_port = mj[3][i[PORT_SITE]]
    if not i[MONITOR_STARTED]:
        f[MONITOR_P_START : MONITOR_P_START + 3] = p_port
        i[MONITOR_STARTED] = 1
    for j in range(3):
        f[MONITOR_FORCE_SUM + j] += f[W_WORLD + j]
    i[MONITOR_TICKS] += 1
    return Stop.MONITOR_WINDOW if i[MONITOR_TICKS] >= i[MONITOR_TICKS_PER_WINDOW] else Stop.RAN


@njit(cache=True, nogil=True)
def _tail(mj: tuple, f: np.ndarray, i: np.ndarray, n_substeps: int) -> int:
    """The rest of a tick: eq. 5 + DLS to the servos, then the physics."""
    if not command(mj, f, i):
        return Stop.NON_FINITE
    time = mj[5]
    before_s = time[0]
    for _ in range(n_substeps):
        mj_step(i[M_ADDRESS], i[D_ADDRESS])
    # MuJoCo resets the data, time included, when qpos, qvel or qacc go bad (its warnings say which)
    return Stop.UNSTABLE if time[0] <= before_s else Stop.RAN


@njit(cache=True, nogil=True)
def run_ticks(mj: tuple, f: np.ndarray, i: np.ndarray, n_ticks: int, n_substeps: int, until_s: float) -> int:
    """Run up to `n_ticks` control ticks, and none after one that ends at or past sim time
    `until_s` [s]; the ticks finished. i[STOP] says why it returned and i[MID_TICK] whether the
    last tick still waits for its servo command and step (`finish_tick`). A fault stops after the
    tick it happened in."""
    i[STOP] = Stop.RAN
    i[MID_TICK] = 0
    for k in range(n_ticks):
        stop = _head(mj, f, i)
        if stop != Stop.RAN:
            i[STOP] = stop
            i[MID_TICK] = 1
            return k
        stop = _tail(mj, f, i, n_substeps)
        if stop != Stop.RAN:
            i[STOP] = stop
            return k + 1
        if mj[5][0] >= until_s:
            return k + 1
    return n_ticks


@njit(cache=True, nogil=True)
def finish_tick(mj: tuple, f: np.ndarray, i: np.ndarray, n_substeps: int) -> int:
    """Command the servos and step a tick `run_ticks` returned in the middle of; a Stop code."""
    i[MID_TICK] = 0
    stop = _tail(mj, f, i, n_substeps)
    i[STOP] = stop
    return stop

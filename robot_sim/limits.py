"""Input limits and the stiffness/damping range the controller is stable and first-order in.

Damping floor (contact stability). Measured on the `surface` scene (rigid plate, probe tool,
1 kHz control, contact solref 10 ms), a 15 N press held 2 s, K = 2-16 kN/m: the force's std
after settling, per translational damping B [N s/m]:

    F/T signal, servo kv        B = 100   125   150   175   200   300   500   800
    raw, kv x 1 (before)          unst  unst  unst  unst  56 N  25 N  12 N  0.00
    100 Hz low-pass, kv x 1       unst  26 N  21 N  6.7 N 0.00  0.00  0.00  0.00
    100 Hz low-pass, kv x 0.7     26 N  6 N   0.00  0.00  0.00  0.00  0.00  0.00   (now)

The cause was the loop, not the plate: the limit cycle sits at 450-500 Hz (the 1 kHz loop's
Nyquist), and the joint servos' velocity feed-forward acts in contact as a ~650 N s/m damper
in series with 1/B. Contact softness and sensor delay did not move the floor. The controller
now low-passes the F/T signal it feeds back (FT_CUTOFF_HZ, 100 Hz; thresholds stay on the raw
signal) and the feed-forward gains are 0.7 of what they were (irb120.xml): B = 150 settles,
and the floor is set at 200 N s/m, 1.33x above the last stable value.

Time-constant floor (free-space fidelity). A step of the attractor should give a first-order
lag: overshoot < 5 % and the 63 % time within 10 % of B/K. A true first-order step asks for an
instant jump in speed; the drives' acceleration limit (controller.JOINT_ACCEL_LIMIT, ~16 m/s^2
at the tool) delays it by about v0/2a, v0 = step/tau. Measured at home, worst axis: a 100 mm
step reaches 63 % at 2.9 tau (50 % overshoot) for tau = 0.05 s, 1.62 tau at 0.1 s, 1.15 tau at
0.2 s, 1.10 tau at 0.25 s and 1.07 tau at 0.3 s; a 0.5 rad step 1.08 tau at 0.2 s. Hence
B/K >= 0.3 s on translation axes and >= 0.2 s on rotation axes.
"""

import math

MAX_DURATION_S = 600.0
MAX_TRANSLATION_M = 1.0
MAX_ROTATION_RAD = math.pi
MAX_GRIPPER_S = 5.0  # [s] a gripper command's duration
MAX_DITHER_AMPLITUDE = 0.35  # [rad] torsional tilt; translational radius has its own cap below
MAX_DITHER_RADIUS_M = 0.02
MAX_DITHER_FREQUENCY_HZ = 10.0
# [s] a gripper's closing time constant (a scene parameter, robot_sim/scenes/grasp.py): MuJoCo
# holds a constraint's time constant to >= 2 physics steps (2 ms); 50 ms is a slow electric
# gripper's (a part pulled in over ~0.15 s).
GRIPPER_CLOSE_S = (0.002, 0.05)
# [m] the least `progress` a dither may end on: at or below its 1 mm tolerance it would end at once
MIN_DITHER_PROGRESS_M = 0.002
# Caps on thresholds: a threshold must be able to end a behavior. 500 N / 50 N m is far above
# any wrench the compliance presets reach in the tasks (tens of N), and far below what would
# read as "no limit" (a 1e308 N threshold passed validation before).
MAX_FORCE_THRESHOLD_N = 500.0
MAX_TORQUE_THRESHOLD_NM = 50.0
# [s] how far a sender's clock may lead the robot's in `sent_at` (the server's --sent-at-skew
# default): more would let a stamp keep a command fresh past its max_age.
SENT_AT_SKEW_S = 5.0
COMMAND_QUEUE_MAX = 64  # queued commands; beyond it a command is refused (POST: 429)
COMMAND_HISTORY_MAX = 1000  # ended commands kept (GET /api/commands)
MAX_SEED = 2**32 - 1  # scene seeds: numpy takes any non-negative int; one range to document

STIFFNESS_MAX = (20000.0, 20000.0, 20000.0, 1000.0, 1000.0, 1000.0)  # [N/m x3, N m/rad x3]
DAMPING_MIN = (200.0, 200.0, 200.0, 20.0, 20.0, 20.0)  # [N s/m x3, N m s/rad x3]
DAMPING_MAX = (50000.0, 50000.0, 50000.0, 2000.0, 2000.0, 2000.0)
# [s] B/K on every axis with K > 0: steps up to 100 mm / 0.5 rad stay first-order (see above).
MIN_TIME_CONSTANT_S = (0.3, 0.3, 0.3, 0.2, 0.2, 0.2)

_AXES = ("x", "y", "z", "rx", "ry", "rz")
_K_UNITS = ("N/m",) * 3 + ("N m/rad",) * 3
_B_UNITS = ("N s/m",) * 3 + ("N m s/rad",) * 3


def check_gains(
    stiffness: "list[float] | tuple[float, ...]", damping: "list[float] | tuple[float, ...]"
) -> None:
    """Raise ValueError naming the first component outside the stable range."""
    for i, (k, b) in enumerate(zip(stiffness, damping, strict=True)):
        axis = _AXES[i]
        if not (math.isfinite(k) and math.isfinite(b)):
            raise ValueError(f"stiffness[{i}] and damping[{i}] ({axis}) must be finite")
        if not 0.0 <= k <= STIFFNESS_MAX[i]:
            raise ValueError(
                f"stiffness[{i}] ({axis}) must be in [0, {STIFFNESS_MAX[i]:g}] {_K_UNITS[i]}, got {k:g}"
            )
        if b <= 0.0:
            raise ValueError(
                f"damping[{i}] ({axis}) must be > 0 {_B_UNITS[i]}, in [{DAMPING_MIN[i]:g}, "
                f"{DAMPING_MAX[i]:g}], got {b:g}"
            )
        if not DAMPING_MIN[i] <= b <= DAMPING_MAX[i]:
            raise ValueError(
                f"damping[{i}] ({axis}) must be in [{DAMPING_MIN[i]:g}, {DAMPING_MAX[i]:g}] {_B_UNITS[i]} "
                f"(the range the controller is stable in), got {b:g}"
            )
        if k > 0.0 and b / k < MIN_TIME_CONSTANT_S[i]:
            raise ValueError(
                f"damping[{i}]/stiffness[{i}] ({axis}) must be >= {MIN_TIME_CONSTANT_S[i]:g} s "
                f"(faster responses are not first-order: the drives' acceleration limit shows), "
                f"got {b / k:.4g} s"
            )

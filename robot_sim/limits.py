"""Input limits and the stiffness/damping range the controller is stable in.

The damping floors were measured on the `surface` scene (rigid plate, probe tool, 1 kHz
control, contact solref 10 ms): pressing 5-20 mm past the plate with K up to 16 kN/m,
translational damping below ~650 N s/m ends in a contact limit cycle, 700 N s/m and above
settles. 800 N s/m leaves margin. The time-constant floor keeps the free-space response a clean
first-order lag: below ~50 ms the joint servos' own lag (~10 ms) shows.
"""

import math

MAX_DURATION_S = 600.0
MAX_TRANSLATION_M = 1.0
MAX_ROTATION_RAD = math.pi
MAX_DITHER_AMPLITUDE = 0.35  # [rad] torsional tilt; translational radius has its own cap below
MAX_DITHER_RADIUS_M = 0.02
MAX_DITHER_FREQUENCY_HZ = 10.0

STIFFNESS_MAX = (20000.0, 20000.0, 20000.0, 1000.0, 1000.0, 1000.0)  # [N/m x3, N m/rad x3]
DAMPING_MIN = (800.0, 800.0, 800.0, 20.0, 20.0, 20.0)  # [N s/m x3, N m s/rad x3]
DAMPING_MAX = (50000.0, 50000.0, 50000.0, 2000.0, 2000.0, 2000.0)
MIN_TIME_CONSTANT_S = 0.05  # B/K on every axis with K > 0

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
            raise ValueError(f"damping[{i}] ({axis}) must be > 0 {_B_UNITS[i]}, got {b:g}")
        if not DAMPING_MIN[i] <= b <= DAMPING_MAX[i]:
            raise ValueError(
                f"damping[{i}] ({axis}) must be in [{DAMPING_MIN[i]:g}, {DAMPING_MAX[i]:g}] {_B_UNITS[i]} "
                f"(the range the controller is stable in), got {b:g}"
            )
        if k > 0.0 and b / k < MIN_TIME_CONSTANT_S:
            raise ValueError(
                f"damping[{i}]/stiffness[{i}] ({axis}) must be >= {MIN_TIME_CONSTANT_S:g} s, "
                f"got {b / k:.4g} s"
            )

"""What held the port back while a behavior ran: every limit, for how long, and which joints
stood at which end of their range (the compiled loop counts them: tick.py). A report's `detail`
says all of them (a port left short of its goal by a joint limit and a singularity at once
names both)."""

import math

import numpy as np

from robot_sim.controller import Limit


def held_back_detail(
    seconds: dict[Limit, float], joint_ends: dict[int, str], joint_range_rad: np.ndarray
) -> str:
    """`limited: joint_limit (6.41 s; joint 5 at its upper end, +120 deg), singularity
    (1.20 s)`: longest first; "" if nothing held the port back. `seconds` [s] per limit,
    `joint_ends` the end ("lower" | "upper") each held joint stood at."""
    if not seconds:
        return ""
    parts = []
    for limit, held_s in sorted(seconds.items(), key=lambda item: -item[1]):
        joints = ""
        if limit is Limit.JOINT_LIMIT and joint_ends:
            joints = "; " + ", ".join(
                f"joint {joint + 1} at its {end} end, "
                f"{math.degrees(joint_range_rad[joint, 0 if end == 'lower' else 1]):+.0f} deg"
                for joint, end in sorted(joint_ends.items())
            )
        parts.append(f"{limit.value} ({held_s:.2f} s{joints})")
    return "limited: " + ", ".join(parts)

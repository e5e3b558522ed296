"""What held the port back while a behavior ran: every limit, for how long, and which joints
stood at which end of their range. A report's `detail` says all of them (a port left short of
its goal by a joint limit and a singularity at once names both)."""

import math

import numpy as np

from robot_sim.controller import AdmittanceController, Limit


class HeldBack:
    def __init__(self) -> None:
        self.seconds: dict[Limit, float] = {}  # [s] per limit
        self._joint_ends: dict[int, str] = {}  # joint index -> "lower" | "upper"

    def add(self, ctl: AdmittanceController, dt_s: float) -> None:
        """(each tick a limit held) Count this tick for every limit that held."""
        for limit in ctl.limits:
            self.seconds[limit] = self.seconds.get(limit, 0.0) + dt_s
        for joint, end in ctl.joints_held:
            self._joint_ends[joint] = end

    def detail(self, joint_range_rad: np.ndarray) -> str:
        """`limited: joint_limit (6.41 s; joint 5 at its upper end, +120 deg), singularity
        (1.20 s)`: longest first; "" if nothing held the port back."""
        if not self.seconds:
            return ""
        parts = []
        for limit, seconds in sorted(self.seconds.items(), key=lambda item: -item[1]):
            joints = ""
            if limit is Limit.JOINT_LIMIT and self._joint_ends:
                joints = "; " + ", ".join(
                    f"joint {joint + 1} at its {end} end, "
                    f"{math.degrees(joint_range_rad[joint, 0 if end == 'lower' else 1]):+.0f} deg"
                    for joint, end in sorted(self._joint_ends.items())
                )
            parts.append(f"{limit.value} ({seconds:.2f} s{joints})")
        return "limited: " + ", ".join(parts)

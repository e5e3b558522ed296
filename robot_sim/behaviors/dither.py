"""Dither (paper 2.2.3): wiggle the attractor while it advances or retreats along an axis.

`axis` is given in `frame` (the tool's, by default; or base, or a task frame) and fixed in base
axes at the start. The attractor's centre
moves from where the attractor is at start by `travel` along the axis (push: forward, pull:
backward) over `duration`, and around that centre:

- torsional (the paper's): the attractor turns back and forth about the dither axis by
  +-`amplitude` [rad] at `frequency`, its origin on the axis;
- translational: the orientation is fixed and the origin circles the axis at radius
  `amplitude` [m] at `frequency`.

The wiggle's amplitude ramps in over its first cycle, so the attractor never jumps. (A conical
wobble of the axis was tried as a third mode and dropped: it recovered 1 of 12 sleeve jams
where the paper's twist recovers 12 of 12; see robot_sim/policies/sleeve_on_peg.py.)
Exits: `wrench_breach` (thresholds, then `on_breach`), `goal_reached` when the port has moved
`progress` (default: the travel) from where it was at start (to within TRAVEL_TOLERANCE_M): a
push that should end once a jam frees advances the attractor by `travel` but stops on a shorter
`progress`; `timeout` at the watchdog.
"""

import math

import mujoco
import numpy as np

from robot_sim.behaviors.base import Behavior, ExitCondition, end_breach, wrench_breached
from robot_sim.controller import AdmittanceController
from robot_sim.params import DitherParams, MonitorSpec
from robot_sim.pose_math import rotate_world
from robot_sim.task_frames import TaskFrames

TRAVEL_TOLERANCE_M = 0.001


def perpendicular_basis(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors completing `axis` (unit) to a right-handed frame."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(axis, helper)
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(axis, e1)


class Dither(Behavior):
    kind = "dither"

    def __init__(self, params: DitherParams) -> None:
        self.params = params
        self.axis_world = np.zeros(3)
        self._e1 = np.zeros(3)
        self._e2 = np.zeros(3)
        self._p_world_port_start = np.zeros(3)
        self._p_world_from = np.zeros(3)  # attractor at start: the centre's origin
        self._q_world_from = np.zeros(4)
        self._sign = 1.0 if params.direction == "push" else -1.0
        self._ends_at_m = params.travel if params.progress is None else params.progress
        self._wiggle = np.zeros(3)
        self._q_tmp = np.zeros(4)
        self._t0 = 0.0

    def monitor_spec(self) -> MonitorSpec | None:
        return self.params.monitor

    def start(self, ctl: AdmittanceController, t: float, frames: TaskFrames) -> None:
        self._t0 = t
        self._p_world_port_start[:] = ctl.p_world_port
        self._p_world_from[:] = ctl.p_world_attractor
        self._q_world_from[:] = ctl.q_world_attractor
        axis_in_frame = np.asarray(self.params.axis, dtype=float)  # unit length (params.py)
        self.axis_world[:] = frames.axes_world(self.params.frame, ctl.q_world_port) @ axis_in_frame
        self._e1[:], self._e2[:] = perpendicular_basis(self.axis_world)

    def progress(self, ctl: AdmittanceController) -> float:
        """How far the port has gone along the axis in the commanded direction [m]."""
        moved = ctl.p_world_port - self._p_world_port_start
        return self._sign * float(moved @ self.axis_world)

    def update(self, ctl: AdmittanceController, t: float) -> ExitCondition | None:
        p = self.params
        if wrench_breached(ctl, p.force_threshold, p.torque_threshold):
            return end_breach(ctl, p.on_breach, p.force_threshold, p.torque_threshold)
        if self.progress(ctl) >= self._ends_at_m - TRAVEL_TOLERANCE_M:
            return ExitCondition.GOAL_REACHED
        elapsed = t - self._t0
        assert p.watchdog is not None
        if elapsed >= p.watchdog:
            return ExitCondition.TIMEOUT
        advance = self._sign * p.travel * min(1.0, elapsed / p.duration)
        amplitude = p.amplitude * min(1.0, elapsed * p.frequency)
        phase = 2.0 * math.pi * p.frequency * elapsed
        mujoco.mju_addScl3(ctl.p_world_attractor, self._p_world_from, self.axis_world, advance)
        if p.mode == "torsional":
            mujoco.mju_scl3(self._wiggle, self.axis_world, amplitude * math.sin(phase))
            rotate_world(ctl.q_world_attractor, self._q_world_from, self._wiggle, 1.0, self._q_tmp)
        else:
            mujoco.mju_scl3(self._wiggle, self._e1, amplitude * math.cos(phase))
            mujoco.mju_addToScl3(self._wiggle, self._e2, amplitude * math.sin(phase))
            mujoco.mju_addTo3(ctl.p_world_attractor, self._wiggle)
            ctl.q_world_attractor[:] = self._q_world_from
        return None

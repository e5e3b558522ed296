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
`progress` (default: the travel) from where it was at start (to within tick.TRAVEL_TOLERANCE_M): a
push that should end once a jam frees advances the attractor by `travel` but stops on a shorter
`progress`; `timeout` at the watchdog.
"""

import numpy as np

from robot_sim import tick
from robot_sim.behaviors.base import Behavior, ExitCondition, end_breach
from robot_sim.controller import AdmittanceController
from robot_sim.params import DitherParams, MonitorSpec
from robot_sim.task_frames import TaskFrames


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

    def monitor_spec(self) -> MonitorSpec | None:
        return self.params.monitor

    def start(self, ctl: AdmittanceController, t: float, frames: TaskFrames) -> None:
        p = self.params
        axis_in_frame = np.asarray(p.axis, dtype=float)  # unit length (params.py)
        self.axis_world[:] = frames.axes_world(p.frame, ctl.q_world_port) @ axis_in_frame
        e1, e2 = perpendicular_basis(self.axis_world)
        assert p.watchdog is not None
        ctl.start_motion(tick.MOTION_DITHER, t, p.duration, p.watchdog, p.force_threshold, p.torque_threshold)
        f = ctl.f
        f[tick.P_PORT_START : tick.P_PORT_START + 3] = ctl.p_world_port
        f[tick.AXIS_WORLD : tick.AXIS_WORLD + 3] = self.axis_world
        f[tick.E1 : tick.E1 + 3] = e1
        f[tick.E2 : tick.E2 + 3] = e2
        f[tick.SIGN] = 1.0 if p.direction == "push" else -1.0
        f[tick.ENDS_AT] = p.travel if p.progress is None else p.progress  # [m]
        f[tick.TRAVEL] = p.travel
        f[tick.AMPLITUDE] = p.amplitude
        f[tick.FREQUENCY] = p.frequency
        torsional = p.mode == "torsional"
        ctl.i[tick.DITHER_MODE] = tick.DITHER_TORSIONAL if torsional else tick.DITHER_TRANSLATIONAL

    def exit_for(self, ctl: AdmittanceController, stop: int) -> ExitCondition:
        if stop == tick.Stop.WRENCH_BREACH:
            p = self.params
            return end_breach(ctl, p.on_breach, p.force_threshold, p.torque_threshold)
        return super().exit_for(ctl, stop)

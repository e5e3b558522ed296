"""RWE, Reset Wrench Equilibrium (paper 2.2.2), axis-selective.

Every tick the attractor is put back on the port along the selected axes, so the virtual
wrench there is zero and only the sensed wrench drives the port: contact forces relax. On the
other axes the stretch held at the start is kept (the attractor moves with the port), so e.g.
an insertion force along z survives an RWE on x, y (the paper's variant, 2.3.5). The axes are
base axes, the port's axes at start with `frame: tool` (keep the force along a tilted tool), or
a task frame's (relieve across a peg's axis, keep the push along it).

After `duration` it ends `completed` if the wrench on the selected axes is below the residuals,
else `timeout` (the environment still pushes: the operator should know).
"""

import math

import numpy as np

from robot_sim import tick
from robot_sim.behaviors.base import Behavior, ExitCondition
from robot_sim.controller import AdmittanceController
from robot_sim.params import RweParams
from robot_sim.pose_math import turn6
from robot_sim.task_frames import TaskFrames


class Rwe(Behavior):
    kind = "rwe"

    def __init__(self, params: RweParams) -> None:
        self.params = params
        self._mask = np.array(params.axis_mask(), dtype=bool)  # (6,) True: relieve this axis
        self._R_world_axes = np.eye(3)

    def start(self, ctl: AdmittanceController, t: float, frames: TaskFrames) -> None:
        ctl.measure_stretch()
        self._R_world_axes = frames.axes_world(self.params.frame, ctl.q_world_port)
        stretch_axes = turn6(self._R_world_axes.T, ctl.stretch_world())
        kept_stretch = turn6(self._R_world_axes, np.where(self._mask, 0.0, stretch_axes))  # base axes
        ctl.start_motion(tick.MOTION_RWE, t, self.params.duration)
        ctl.f[tick.KEPT_STRETCH : tick.KEPT_STRETCH + 6] = kept_stretch
        ctl.place_attractor_from_port(kept_stretch)

    def exit_for(self, ctl: AdmittanceController, stop: int) -> ExitCondition:
        assert stop == tick.Stop.DURATION_ENDED, stop
        return ExitCondition.COMPLETED if self.relieved(ctl.w_world_env_on_port) else ExitCondition.TIMEOUT

    def relieved(self, wrench_world: np.ndarray) -> bool:
        selected = np.where(self._mask, turn6(self._R_world_axes.T, wrench_world), 0.0)
        force = math.sqrt(float(selected[0:3] @ selected[0:3]))
        torque = math.sqrt(float(selected[3:6] @ selected[3:6]))
        return force <= self.params.force_residual and torque <= self.params.torque_residual

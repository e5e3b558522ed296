"""PTWL, Pose Target Wrench Limiting (paper 2.2.1).

The attractor starts on the port and moves at constant velocity (linear in position, constant
angular velocity in orientation) to port-at-start (+) displacement over `duration`. It ends
`wrench_breach` when |f| or |tau| passes its threshold (checked first: safety before success),
`goal_reached` when the port is within both tolerances of the target, `timeout` at the
watchdog. Displacements are in the port's frame at start (`tool`) or base axes (`base`); both
rotate about the port's origin.
"""

import mujoco
import numpy as np

from robot_sim.behaviors.base import Behavior, ExitCondition, wrench_breached
from robot_sim.controller import AdmittanceController
from robot_sim.params import PtwlParams
from robot_sim.pose_math import angle_between, rotate_world, rotation_matrix


class Ptwl(Behavior):
    kind = "ptwl"

    def __init__(self, params: PtwlParams) -> None:
        self.params = params
        self.p_world_goal = np.zeros(3)
        self.q_world_goal = np.zeros(4)
        self._p_world_start = np.zeros(3)
        self._q_world_start = np.zeros(4)
        self._dp_world = np.zeros(3)  # [m] translation to the goal, base axes
        self._rotvec_world = np.zeros(3)  # [rad] rotation to the goal, base axes
        self._q_tmp = np.zeros(4)
        self._v_tmp = np.zeros(3)
        self._t0 = 0.0
        self._rotates = False
        self._arrived = False

    def start(self, ctl: AdmittanceController, t: float) -> None:
        p = self.params
        gains = p.gains()
        if gains is not None:
            ctl.set_gains(gains)
        self._t0 = t
        self._p_world_start[:] = ctl.p_world_port
        self._q_world_start[:] = ctl.q_world_port
        translation = np.asarray(p.translation, dtype=float)
        rotation = np.asarray(p.rotation, dtype=float)
        if p.frame == "tool":
            R_world_port = rotation_matrix(self._q_world_start)
            self._dp_world[:] = R_world_port @ translation
            self._rotvec_world[:] = R_world_port @ rotation
        else:
            self._dp_world[:] = translation
            self._rotvec_world[:] = rotation
        self.p_world_goal[:] = self._p_world_start + self._dp_world
        rotate_world(self.q_world_goal, self._q_world_start, self._rotvec_world, 1.0, self._q_tmp)
        self._rotates = bool(np.any(rotation != 0.0))
        self._arrived = False
        ctl.place_attractor_from_port(np.zeros(6))

    def update(self, ctl: AdmittanceController, t: float) -> ExitCondition | None:
        p = self.params
        if wrench_breached(ctl, p.force_threshold, p.torque_threshold):
            return ExitCondition.WRENCH_BREACH
        if (
            mujoco.mju_dist3(self.p_world_goal, ctl.p_world_port) <= p.position_tolerance
            and angle_between(self.q_world_goal, ctl.q_world_port, self._v_tmp) <= p.orientation_tolerance
        ):
            return ExitCondition.GOAL_REACHED
        elapsed = t - self._t0
        assert p.watchdog is not None
        if elapsed >= p.watchdog:
            return ExitCondition.TIMEOUT
        if self._arrived:
            return None  # the attractor sits on the goal; nothing to move
        alpha = elapsed / p.duration
        if alpha >= 1.0:
            alpha = 1.0
            self._arrived = True
        mujoco.mju_addScl3(ctl.p_world_attractor, self._p_world_start, self._dp_world, alpha)
        if self._rotates:
            rotate_world(ctl.q_world_attractor, self._q_world_start, self._rotvec_world, alpha, self._q_tmp)
        return None

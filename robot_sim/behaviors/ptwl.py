"""PTWL, Pose Target Wrench Limiting (paper 2.2.1).

The goal is the port pose at start (+) the displacement; the attractor travels there from
where it is now (re-placed first if the PTWL brings other stiffness, so the spring's pull is
unchanged: `AdmittanceController.change_gains`) at constant velocity (linear in position,
constant angular velocity in orientation) over `duration`. Starting from the current
attractor, not the port, keeps a held force through the start, and makes a PTWL that pushes
further after a breach breach again at once: the paper's "stuck" that RWE relieves (2.2.2).

Exits: `wrench_breach` when |f| or |tau| passes its threshold (checked first: safety before
success; then `on_breach` says where the attractor goes), `goal_reached` when the port is
within both tolerances of the goal, `timeout` at the watchdog. Displacements are in the port's
frame at start (`tool`), base axes (`base`) or a task frame's axes; all rotate about the port's
origin.
"""

import math

import mujoco
import numpy as np

from robot_sim import tick
from robot_sim.behaviors.base import Behavior, ExitCondition, Pose, PoseArrays, end_breach
from robot_sim.controller import AdmittanceController
from robot_sim.params import MonitorSpec, PtwlParams
from robot_sim.pose_math import angle_between, rotate_world, rotvec_from_to
from robot_sim.task_frames import TaskFrames


def ptwl_goal(
    p_world_port: np.ndarray, q_world_port: np.ndarray, params: PtwlParams, frames: TaskFrames
) -> PoseArrays:
    """(position [m], quaternion wxyz) of the goal: port (+) displacement, base frame."""
    return displaced(p_world_port, q_world_port, params.translation, params.rotation, params.frame, frames)


def displaced(
    p_world_port: "np.ndarray | list[float]",
    q_world_port: "np.ndarray | list[float]",
    translation_m: "np.ndarray | list[float]",
    rotation_rad: "np.ndarray | list[float]",
    frame: str,
    frames: TaskFrames,
) -> PoseArrays:
    """Port (+) displacement: the translation and rotation vector in `frame`'s axes (the port's
    at start for `tool`), the rotation about the port's origin; (position [m], wxyz), base frame.
    The one rule, for the robot and for a console drawing where a PTWL will go."""
    R_world_axes = frames.axes_world(frame, q_world_port)
    translation = R_world_axes @ np.asarray(translation_m, dtype=float)
    rotation = R_world_axes @ np.asarray(rotation_rad, dtype=float)
    q_goal = np.zeros(4)
    rotate_world(q_goal, np.asarray(q_world_port, dtype=float), rotation, 1.0, np.zeros(4))
    return np.asarray(p_world_port, dtype=float) + translation, q_goal


def displacement_between(
    p_world_port: "np.ndarray | list[float]",
    q_world_port: "np.ndarray | list[float]",
    p_world_goal: "np.ndarray | list[float]",
    q_world_goal: "np.ndarray | list[float]",
    frame: str,
    frames: TaskFrames,
) -> tuple[np.ndarray, np.ndarray]:
    """The (translation [m], rotation vector [rad]) in `frame`'s axes that `displaced` maps the
    port to the goal with (a target dragged in 3D, written back as a PTWL)."""
    R_axes_world = frames.axes_world(frame, q_world_port).T
    dp_world = np.asarray(p_world_goal, dtype=float) - np.asarray(p_world_port, dtype=float)
    rotvec_world = rotvec_from_to(
        np.asarray(q_world_port, dtype=float), np.asarray(q_world_goal, dtype=float)
    )
    return R_axes_world @ dp_world, R_axes_world @ rotvec_world


class Ptwl(Behavior):
    kind = "ptwl"

    def __init__(self, params: PtwlParams) -> None:
        self.params = params
        self.p_world_goal = np.zeros(3)
        self.q_world_goal = np.zeros(4)
        self._v_tmp = np.zeros(3)

    def monitor_spec(self) -> MonitorSpec | None:
        return self.params.monitor

    def start(self, ctl: AdmittanceController, t: float, frames: TaskFrames) -> None:
        p = self.params
        ctl.change_gains(frames.resolve_gains(p.gains(ctl.gains)))
        goal = ptwl_goal(ctl.p_world_port, ctl.q_world_port, p, frames)
        self.p_world_goal[:], self.q_world_goal[:] = goal
        assert p.watchdog is not None
        ctl.start_motion(tick.MOTION_PTWL, t, p.duration, p.watchdog, p.force_threshold, p.torque_threshold)
        f = ctl.f
        f[tick.POSITION_TOLERANCE] = p.position_tolerance
        f[tick.ORIENTATION_TOLERANCE] = p.orientation_tolerance
        f[tick.P_GOAL : tick.P_GOAL + 3] = self.p_world_goal
        f[tick.Q_GOAL : tick.Q_GOAL + 4] = self.q_world_goal
        f[tick.DP_WORLD : tick.DP_WORLD + 3] = self.p_world_goal - ctl.p_world_attractor  # [m]
        rotvec_world = rotvec_from_to(ctl.q_world_attractor, self.q_world_goal)  # [rad]
        f[tick.ROTVEC_WORLD : tick.ROTVEC_WORLD + 3] = rotvec_world
        ctl.i[tick.ROTATES] = int(np.any(rotvec_world != 0.0))
        ctl.i[tick.ARRIVED] = 0

    def goal_pose(self) -> Pose:
        return Pose.of(self.p_world_goal, self.q_world_goal)

    def shortfall(self, ctl: AdmittanceController) -> str:
        distance_m = mujoco.mju_dist3(self.p_world_goal, ctl.p_world_port)
        angle_rad = angle_between(self.q_world_goal, ctl.q_world_port, self._v_tmp)
        return f"port {1000.0 * distance_m:.1f} mm and {math.degrees(angle_rad):.1f} deg from its goal"

    def exit_for(self, ctl: AdmittanceController, stop: int) -> ExitCondition:
        if stop == tick.Stop.WRENCH_BREACH:
            p = self.params
            return end_breach(ctl, p.on_breach, p.force_threshold, p.torque_threshold)
        return super().exit_for(ctl, stop)

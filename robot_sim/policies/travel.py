"""What an onboard machine can tell from the port's pose and wrench alone, without a model of the
workpiece: how far the port has gone down the tool's axis, how far that axis has swung, how far
the tool has turned about it, each since the start; the torque across the tool axis; and a new
approach turned from an old one."""

import mujoco
import numpy as np

from robot_sim.behaviors import BehaviorReport, Pose
from robot_sim.pose_math import rotation_matrix


def travel_down_tool_axis_m(start: Pose, now: Pose) -> float:
    axis = rotation_matrix(np.asarray(start.quaternion))[:, 2]
    return float(axis @ (np.asarray(now.position) - np.asarray(start.position)))


def tool_axis_tilt_rad(start: Pose, now: Pose) -> float:
    """How far the tool's z axis has swung from where it pointed at the start (a hinge's angle,
    when the tool holds what turns on it)."""
    z_start = rotation_matrix(np.asarray(start.quaternion))[:, 2]
    z_now = rotation_matrix(np.asarray(now.quaternion))[:, 2]
    return float(np.arccos(np.clip(z_start @ z_now, -1.0, 1.0)))


def twist_about_tool_axis_rad(start: Pose, now: Pose) -> float:
    """The turn about the tool's own z axis since the start (a knob's turn), for small tilts."""
    R_rel = rotation_matrix(np.asarray(start.quaternion)).T @ rotation_matrix(np.asarray(now.quaternion))
    return float(np.arctan2(R_rel[1, 0], R_rel[0, 0]))


def turned_in_tool_axes(start: Pose, turn_xy_rad: np.ndarray) -> Pose:
    """`start` turned about its own tool x and y axes by the rotation vector (x, y) [rad]: the
    same port position, the tool axis tilted (a new approach to retry an insertion along)."""
    quaternion = np.array(start.quaternion, dtype=float)
    mujoco.mju_quatIntegrate(quaternion, np.array([turn_xy_rad[0], turn_xy_rad[1], 0.0]), 1.0)
    return Pose.of(start.position, quaternion)


def torque_in_tool_xy(report: BehaviorReport) -> np.ndarray:
    """(2,) [N m] the final torque on the port about its own x and y axes (across the tool axis)."""
    R_world_port = rotation_matrix(np.asarray(report.final_port.quaternion))
    return (R_world_port.T @ np.asarray(report.final_wrench[3:6], dtype=float))[0:2]

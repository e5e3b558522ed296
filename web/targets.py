"""Where a PTWL would take the port: port (+) displacement, as the robot computes it.

Mirrors robot_sim's PTWL so the contemplated and commanded displays show the target before the
robot reports anything: `tool` displacements are in the port's frame at start, `base` ones in
base axes, a task frame's in its axes (robot_sim/task_frames.py: the one rule for which axes a
name means); all rotate about the port's origin. Poses are (position [m], wxyz).
"""

import numpy as np
import viser.transforms as tf

from robot_sim.task_frames import TaskFrames

Pose = tuple[np.ndarray, np.ndarray]


def _axes(port: Pose, frame: str, frames: TaskFrames) -> tf.SO3:
    return tf.SO3.from_matrix(frames.axes_world(frame, np.asarray(port[1], dtype=float)))


def ptwl_target(
    port: Pose, translation_m: np.ndarray, rotation_rad: np.ndarray, frame: str, frames: TaskFrames
) -> Pose:
    p_world_port, q_world_port = port
    R_world_port = tf.SO3(np.asarray(q_world_port, dtype=float))
    R_world_axes = _axes(port, frame, frames)
    dp_world = R_world_axes.apply(np.asarray(translation_m, dtype=float))
    rotvec_world = R_world_axes.apply(np.asarray(rotation_rad, dtype=float))
    R_world_goal = tf.SO3.exp(rotvec_world) @ R_world_port
    return np.asarray(p_world_port, dtype=float) + dp_world, R_world_goal.wxyz


def displacement_to(
    port: Pose, target: Pose, frame: str, frames: TaskFrames
) -> tuple[np.ndarray, np.ndarray]:
    """The (translation [m], rotation vector [rad]) that ptwl_target maps to `target` (gizmo)."""
    p_world_port, q_world_port = port
    R_world_port = tf.SO3(np.asarray(q_world_port, dtype=float))
    dp_world = np.asarray(target[0], dtype=float) - np.asarray(p_world_port, dtype=float)
    rotvec_world = (tf.SO3(np.asarray(target[1], dtype=float)) @ R_world_port.inverse()).log()
    R_axes_world = _axes(port, frame, frames).inverse()
    return R_axes_world.apply(dp_world), R_axes_world.apply(rotvec_world)

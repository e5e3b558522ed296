"""Where a PTWL would take the port: port (+) displacement, as the robot computes it.

Mirrors robot_sim's PTWL so the contemplated and commanded displays show the target before the
robot reports anything: `tool` displacements are in the port's frame at start, `base` ones in
base axes; both rotate about the port's origin. Poses are (position [m], wxyz).
"""

import numpy as np
import viser.transforms as tf

Pose = tuple[np.ndarray, np.ndarray]


def ptwl_target(port: Pose, translation_m: np.ndarray, rotation_rad: np.ndarray, frame: str) -> Pose:
    p_world_port, q_world_port = port
    R_world_port = tf.SO3(np.asarray(q_world_port, dtype=float))
    if frame == "tool":
        dp_world = R_world_port.apply(np.asarray(translation_m, dtype=float))
        rotvec_world = R_world_port.apply(np.asarray(rotation_rad, dtype=float))
    else:
        dp_world = np.asarray(translation_m, dtype=float)
        rotvec_world = np.asarray(rotation_rad, dtype=float)
    R_world_goal = tf.SO3.exp(rotvec_world) @ R_world_port
    return np.asarray(p_world_port, dtype=float) + dp_world, R_world_goal.wxyz


def displacement_to(port: Pose, target: Pose, frame: str) -> tuple[np.ndarray, np.ndarray]:
    """The (translation [m], rotation vector [rad]) that ptwl_target maps to `target` (gizmo)."""
    p_world_port, q_world_port = port
    R_world_port = tf.SO3(np.asarray(q_world_port, dtype=float))
    dp_world = np.asarray(target[0], dtype=float) - np.asarray(p_world_port, dtype=float)
    rotvec_world = (tf.SO3(np.asarray(target[1], dtype=float)) @ R_world_port.inverse()).log()
    if frame == "tool":
        R_port_world = R_world_port.inverse()
        return R_port_world.apply(dp_world), R_port_world.apply(rotvec_world)
    return dp_world, rotvec_world

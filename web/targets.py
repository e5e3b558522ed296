"""Where a PTWL would take the port, by the robot's own rule (robot_sim/behaviors/ptwl.py:
`displaced`), so the contemplated and commanded displays show the target before the robot
reports anything. Poses here are (position [m], wxyz) arrays, as viser takes them."""

import numpy as np

from robot_sim.behaviors.base import PoseArrays
from robot_sim.behaviors.ptwl import displaced, displacement_between
from robot_sim.task_frames import TaskFrames


def ptwl_target(
    port: PoseArrays, translation_m: np.ndarray, rotation_rad: np.ndarray, frame: str, frames: TaskFrames
) -> PoseArrays:
    return displaced(port[0], port[1], translation_m, rotation_rad, frame, frames)


def displacement_to(
    port: PoseArrays, target: PoseArrays, frame: str, frames: TaskFrames
) -> tuple[np.ndarray, np.ndarray]:
    """The (translation [m], rotation vector [rad]) that ptwl_target maps to `target` (gizmo)."""
    return displacement_between(port[0], port[1], target[0], target[1], frame, frames)

"""What an onboard machine can tell of depth without a model of the workpiece: how far the port
has gone along the tool's z axis (as it pointed at the start) since the start."""

import numpy as np

from robot_sim.behaviors import Pose
from robot_sim.pose_math import rotation_matrix


def travel_down_tool_axis_m(start: Pose, now: Pose) -> float:
    axis = rotation_matrix(np.asarray(start.quaternion))[:, 2]
    return float(axis @ (np.asarray(now.position) - np.asarray(start.position)))

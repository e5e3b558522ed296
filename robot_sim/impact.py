"""What a PTWL's approach speed costs on impact, said before it runs.

A port moving at speed v in free space trails its attractor by the stretch B v / K. When it
meets a rigid surface that stretch turns into contact force, about B v along the motion, before
any exit condition can act: the impact peak is physics, not the threshold. Measured on the
plate with `medium` (B = 1000 N s/m): peaks of 0.6-0.9 B v at 20-160 mm/s; under `freeze` the
held force is ~0.93 B v. So B v over the threshold earns a warning (the 202's `warnings`).
"""

import numpy as np

from robot_sim.gains import Gains
from robot_sim.params import PtwlParams
from robot_sim.task_frames import TaskFrames


def impact_warnings(
    params: PtwlParams, current: Gains, q_world_port: "list[float] | np.ndarray", frames: TaskFrames
) -> list[str]:
    """Warnings for a PTWL whose approach would overshoot its thresholds on contact.

    Args:
        params: the PTWL as validated.
        current: the gains in force now (used unless the PTWL names its own).
        q_world_port: the port's orientation now, wxyz (turns tool-frame vectors and gains).
        frames: the task frames the PTWL's `frame` and `gains_frame` may name (known ones).
    Returns:
        One sentence per threshold that B v passes; empty when the approach is gentle enough.
    """
    gains = params.gains(current)
    R_world_gains = frames.axes_world(gains.frame, q_world_port)
    R_world_move = frames.axes_world(params.frame, q_world_port)
    warnings = []
    checks = (
        (params.translation, gains.damping[0:3], params.force_threshold, "force", "m/s", "N s/m", "N"),
        (params.rotation, gains.damping[3:6], params.torque_threshold, "torque", "rad/s", "N m s/rad", "N m"),
    )
    for move, damping, threshold, what, speed_unit, b_unit, unit in checks:
        move_world = R_world_move @ np.asarray(move, dtype=float)
        length = float(np.linalg.norm(move_world))
        if length == 0.0:
            continue
        direction_gains = R_world_gains.T @ (move_world / length)
        b_along = float(direction_gains**2 @ damping)  # d^T B d, B diagonal in the gains' axes
        speed = length / params.duration
        impact = b_along * speed
        if impact > threshold:
            warnings.append(
                f"approach speed {speed:.3g} {speed_unit} with damping {b_along:.4g} {b_unit} along the "
                f"motion can build ~{impact:.3g} {unit} on contact, over {what}_threshold "
                f"{threshold:g} {unit}: the impact will pass it before the breach acts; a duration of "
                f">= {length * b_along / threshold:.3g} s keeps it under"
            )
    return warnings

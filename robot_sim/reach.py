"""Whether the arm can put its port on a goal pose from where it is: a damped-least-squares
inverse kinematics walk from the current joints with the joint ranges left open, then the
ranges checked. The controller's own motion is a damped-least-squares walk too, so a joint this
walk takes past its end is where the controller's taper will stop the port short (a goal another
branch of the arm could reach is still warned of: that branch is not where the arm will go)."""

import math

import mujoco
import numpy as np

from robot_sim.arm import ArmLayout
from robot_sim.pose_math import rotvec_from_to

STEPS = 200
STALL_STEPS = 20  # a walk that gains less than STALL_M over this many steps has stalled
STALL_M = 1e-4
DAMPING = 0.05  # [m | rad] DLS damping: steps stay short near a singularity
MAX_STEP_RAD = 0.2  # per iteration, per joint
POSITION_TOL_M = 1e-4
ANGLE_TOL_RAD = 1e-3
PAST_RANGE_TOL_RAD = math.radians(0.5)  # closer than this to an end is at it, not past it


def reach_warnings(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    layout: ArmLayout,
    p_world_goal: np.ndarray,
    q_world_goal: np.ndarray,
) -> list[str]:
    """What keeps the port from `(p_world_goal, q_world_goal)` from the arm's joints now: each
    joint the goal needs past an end of its range (by how much), or how far out of reach it is.
    [] if the arm can get there. `data` is read only."""
    scratch = mujoco.MjData(model)
    scratch.qpos[:] = data.qpos
    q = scratch.qpos[layout.qpos_adr].copy()
    jacp, jacr = np.zeros((3, model.nv)), np.zeros((3, model.nv))
    q_port, error = np.zeros(4), np.zeros(6)
    residual_m = math.inf
    history_m: list[float] = []
    for _ in range(STEPS):
        scratch.qpos[layout.qpos_adr] = q
        mujoco.mj_kinematics(model, scratch)
        mujoco.mj_comPos(model, scratch)  # the Jacobian reads the dofs it places
        error[0:3] = p_world_goal - scratch.site_xpos[layout.port_site]
        mujoco.mju_mat2Quat(q_port, scratch.site_xmat[layout.port_site])
        error[3:6] = rotvec_from_to(q_port, q_world_goal)
        residual_m = float(np.linalg.norm(error[0:3]))
        if residual_m < POSITION_TOL_M and np.linalg.norm(error[3:6]) < ANGLE_TOL_RAD:
            break
        history_m.append(residual_m + float(np.linalg.norm(error[3:6])) * 0.1)  # 0.1 m per rad
        if len(history_m) > STALL_STEPS and history_m[-STALL_STEPS - 1] - history_m[-1] < STALL_M:
            return _out_of_reach(residual_m)
        mujoco.mj_jacSite(model, scratch, jacp, jacr, layout.port_site)
        jac = np.vstack((jacp[:, layout.dof_adr], jacr[:, layout.dof_adr]))
        step = jac.T @ np.linalg.solve(jac @ jac.T + DAMPING**2 * np.eye(6), error)
        q += np.clip(step, -MAX_STEP_RAD, MAX_STEP_RAD)
    else:
        return _out_of_reach(residual_m)
    warnings = []
    for joint, (lo, hi) in enumerate(layout.joint_range):
        past_rad = max(lo - q[joint], q[joint] - hi)
        if past_rad > PAST_RANGE_TOL_RAD:
            end, at = ("lower", lo) if q[joint] < lo else ("upper", hi)
            warnings.append(
                f"the goal needs joint {joint + 1} at {math.degrees(q[joint]):+.0f} deg, "
                f"{math.degrees(past_rad):.0f} deg past its {end} end ({math.degrees(at):+.0f} deg): "
                "the port will stop short"
            )
    return warnings


def _out_of_reach(residual_m: float) -> list[str]:
    return [
        f"the goal is out of the arm's reach from where it is: a walk toward it stalls "
        f"{1000.0 * residual_m:.0f} mm from it; the port will stop short"
    ]

"""What the robot warns of a PTWL it accepts (the 202's `warnings`): a move too small to make,
an approach too fast to stop, a goal the arm cannot reach."""

import math

import numpy as np

from robot_sim.behaviors.ptwl import ptwl_goal
from robot_sim.gains import Gains
from robot_sim.impact import impact_warnings
from robot_sim.params import PtwlParams
from robot_sim.reach import reach_warnings
from robot_sim.sim import Simulation
from robot_sim.task_frames import TaskFrames


def ptwl_warnings(params: PtwlParams, sim: Simulation) -> list[str]:
    """(simulation thread) Every warning for an accepted PTWL, judged from the arm as it is now
    (a queued move starts later, from wherever the port is then)."""
    ctl = sim.controller
    p_world_goal, q_world_goal = ptwl_goal(ctl.p_world_port, ctl.q_world_port, params, sim.frames)
    return [
        *move_warnings(params, ctl.gains, ctl.q_world_port, sim.frames),
        *reach_warnings(sim.model, sim.data, sim.layout, p_world_goal, q_world_goal),
    ]


def move_warnings(
    params: PtwlParams, current: Gains, q_world_port: "list[float] | np.ndarray", frames: TaskFrames
) -> list[str]:
    """The warnings judged without the arm's joints (the console's check line before Send gives
    these; the reach check needs the robot): the arguments as for `impact_warnings`."""
    return [*tolerance_warnings(params), *impact_warnings(params, current, q_world_port, frames)]


def tolerance_warnings(params: PtwlParams) -> list[str]:
    """A move within both its tolerances ends `goal_reached` as it starts, without moving (the
    port is already within them of the goal). A zero move is not warned of: it is how a preset
    or gains are changed without moving."""
    move_m = float(np.linalg.norm(params.translation))
    turn_rad = float(np.linalg.norm(params.rotation))
    if move_m == 0.0 and turn_rad == 0.0:
        return []
    if move_m > params.position_tolerance or turn_rad > params.orientation_tolerance:
        return []
    return [
        f"the move ({1000.0 * move_m:.3g} mm, {math.degrees(turn_rad):.3g} deg) is within its tolerances "
        f"({1000.0 * params.position_tolerance:g} mm, {math.degrees(params.orientation_tolerance):.3g} deg): "
        "it ends goal_reached at once without moving; lower position_tolerance or move further"
    ]

"""Tool stowage (paper 2.3.4): the tool in the gripper, over its bay; stow it locked and let go."""

from typing import TYPE_CHECKING

import mujoco
import numpy as np

from robot_sim.scenes.base import HOME_TOOL_DOWN, Scene, TaskProgress
from robot_sim.scenes.grasp import RELPOSE
from robot_sim.scenes.tool_bay import (
    BOTTOMED_M,
    GRIPPER,
    LOCKED_RAD,
    bay_moved,
    held,
    lift_m,
    lock_spring,
    tool_qpos,
    turn_rad,
)

if TYPE_CHECKING:
    from robot_sim.sim import Simulation

HELD_UP_M = 0.020  # the tool starts this far up, its knob in the gripper at the home pose


def _in_the_gripper(model: mujoco.MjModel) -> None:
    """The tool lifted to the gripper and held (the grasp weld on from the start): its knob's
    grasp point on the port, axes matched, at the home pose."""
    model.qpos0[tool_qpos(model) + 2] += HELD_UP_M
    weld = model.equality(GRIPPER.weld).id
    # tool <- port (the port 0.1 m down the gripper's axis) <- grasp site (0.07 m up the knob, z down)
    model.eq_data[weld, RELPOSE] = np.array([0.0, 0.0, 0.170, 0.0, 0.0, 1.0, 0.0])
    model.eq_active0[weld] = 1


def _stowed(sim: "Simulation") -> TaskProgress:
    m, d = sim.model, sim.data
    lift, turn = lift_m(m, d), turn_rad(m, d)
    stowed = lift <= BOTTOMED_M and abs(turn) <= LOCKED_RAD and not held(sim)
    return TaskProgress(
        "tool bottomed in the bay, locked (legs under the tabs), gripper released",
        stowed,
        lift,
        BOTTOMED_M,
        "m",
    )


SCENE = Scene(
    "tool_stowage",
    "The tool held in the gripper 20 mm over its stowage bay's bayonet lock (paper 2.3.4): stow "
    "it, lock it, let go; a seed moves the bay up to 2 mm in x and y.",
    "tool_bay.xml",
    "gripper.xml",
    HOME_TOOL_DOWN,
    None,
    0.0,
    _stowed,
    lock_spring,
    randomise=bay_moved(with_tool=False),
    gripper=GRIPPER,
    prepare=_in_the_gripper,
)

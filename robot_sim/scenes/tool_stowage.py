"""Tool stowage (paper 2.3.4): the tool in the gripper, over its bay; stow it locked and let go."""

from typing import TYPE_CHECKING

import mujoco

from robot_sim.model import ARM_PREFIX, TOOL_PREFIX
from robot_sim.scenes.base import HOME_TOOL_DOWN, Scene, TaskProgress
from robot_sim.scenes.grasp import hold, jaws_relpose
from robot_sim.scenes.tool_bay import (
    BOTTOMED_M,
    GRIPPER,
    Bay,
    bay_moved,
    lock_spring,
    tool_qpos,
)

if TYPE_CHECKING:
    from robot_sim.sim import Simulation

HELD_UP_M = 0.020  # the tool starts this far up, its knob in the gripper at the home pose


def _in_the_gripper(model: mujoco.MjModel) -> None:
    """The tool lifted to the gripper and held (the grasp weld on from the start): its knob's
    grasp point on the port, axes matched, at the home pose."""
    model.qpos0[tool_qpos(model) + 2] += HELD_UP_M
    port = model.site(ARM_PREFIX + TOOL_PREFIX + "port").id
    hold(model, None, model.equality(GRIPPER.weld).id, jaws_relpose(model, GRIPPER, port))


def _stowed(sim: "Simulation") -> TaskProgress:
    bay = Bay.of(sim.model)
    return TaskProgress(
        "tool bottomed in the bay, locked (legs under the tabs), gripper released",
        bay.stowed(sim.data),
        bay.lift_m(sim.data),
        BOTTOMED_M,
        "m",
        at_most=True,
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

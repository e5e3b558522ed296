"""Tool retrieval (paper 2.3.3): grasp the tool locked in its bay, turn the lock open, lift it out."""

from typing import TYPE_CHECKING

from robot_sim.scenes.base import HOME_TOOL_DOWN, Scene, TaskProgress
from robot_sim.scenes.tool_bay import GRIPPER, OUT_M, Bay, bay_moved, lock_spring

if TYPE_CHECKING:
    from robot_sim.sim import Simulation


def _retrieved(sim: "Simulation") -> TaskProgress:
    bay = Bay.of(sim.model)
    return TaskProgress(
        "tool out of the bay (foot >= 40 mm up) in the gripper",
        bay.out(sim.data),
        bay.lift_m(sim.data),
        OUT_M,
        "m",
    )


SCENE = Scene(
    "tool_retrieval",
    "A tool locked in its stowage bay by a spring-loaded bayonet, its knob 20 mm under the open "
    "gripper (paper 2.3.3); a seed moves the bay up to 2 mm in x and y.",
    "tool_bay.xml",
    "gripper.xml",
    HOME_TOOL_DOWN,
    None,
    0.0,
    _retrieved,
    lock_spring,
    randomise=bay_moved(with_tool=True),
    gripper=GRIPPER,
)

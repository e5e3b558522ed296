"""Tool retrieval (paper 2.3.3): grasp the tool locked in its bay, turn the lock open, lift it out."""

from typing import TYPE_CHECKING

from robot_sim.scenes.base import HOME_TOOL_DOWN, Scene, TaskProgress
from robot_sim.scenes.tool_bay import GRIPPER, Bay, bay_moved, held, lock_spring

if TYPE_CHECKING:
    from robot_sim.sim import Simulation

OUT_M = 0.040  # the legs well clear of the bay's 40 mm walls' tabs: out


def _retrieved(sim: "Simulation") -> TaskProgress:
    lift = Bay.of(sim.model).lift_m(sim.data)
    return TaskProgress(
        "tool out of the bay (foot >= 40 mm up) in the gripper", lift >= OUT_M and held(sim), lift, OUT_M, "m"
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

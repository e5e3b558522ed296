"""Plug insertion (paper 2.3.7, Fig. 10): a three-prong plug into an outlet whose place along
y the machine does not know."""

from typing import TYPE_CHECKING

from robot_sim.scenes.base import HOME_TOOL_DOWN, Scene, TaskProgress, port_depth_below_m

if TYPE_CHECKING:
    from robot_sim.sim import Simulation

INSERTED_M = 0.015  # fully inserted: within 1 mm of the plug's body meeting the face


def _plug(sim: "Simulation") -> TaskProgress:
    depth = port_depth_below_m(sim, "outlet_face")  # the prong tips below the face
    return TaskProgress(
        "prongs fully inserted (tips >= 15 mm below the face)", depth >= INSERTED_M, depth, INSERTED_M, "m"
    )


SCENE = Scene(
    "plug",
    "A US three-prong outlet under the plug tool; a seed moves it up to 10 mm in y (unknown "
    "to the machine) and 0.5 mm in x (paper 2.3.7: find the hole by sliding in contact).",
    "plug.xml",
    "plug_tool.xml",
    HOME_TOOL_DOWN,
    "outlet",
    0.0,
    _plug,
    offset_box_m=(0.0005, 0.010),
)

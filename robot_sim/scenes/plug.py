"""Plug insertion (paper 2.3.7, Fig. 10): a three-prong plug into an outlet whose place along
y the machine does not know."""

from typing import TYPE_CHECKING

from robot_sim.scenes.base import HOME_TOOL_DOWN, Scene, TaskProgress

if TYPE_CHECKING:
    from robot_sim.sim import Simulation

PRONG_M = 0.016  # prong length: tips this far below the face when the plug is home
INSERTED_M = 0.015  # fully inserted: within 1 mm of the plug's body meeting the face


def prong_depth_m(sim: "Simulation") -> float:
    """[m] how far the prong tips (the port) are below the outlet's face (negative: above)."""
    face = sim.data.site_xpos[sim.model.site("outlet_face").id]
    return float(face[2] - sim.controller.p_world_port[2])


def _plug(sim: "Simulation") -> TaskProgress:
    depth = prong_depth_m(sim)
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

"""Wide, shallow lid (paper 2.3.9, Fig. 12)."""

import math
from typing import TYPE_CHECKING

import numpy as np

from robot_sim.scenes.base import HOME_TOOL_DOWN, Scene, TaskProgress

if TYPE_CHECKING:
    from robot_sim.sim import Simulation


LID_SEATED_M = 0.0135  # lid underside this far below the lip's top: on the pan's floor (15 mm)
LID_RADIAL_PLAY_M = 0.0025  # lip's inner radius minus the lid's


def _lid(sim: "Simulation") -> TaskProgress:
    m, d = sim.model, sim.data
    port = sim.controller.p_world_port
    depth = float(d.site_xpos[m.site("lip_top").id][2] - port[2])
    off_axis = float(np.linalg.norm((port - d.site_xpos[m.site("pan_centre").id])[0:2]))
    tool_z = d.site_xmat[sim.layout.port_site].reshape(3, 3)[:, 2]
    tilt_deg = math.degrees(math.acos(float(np.clip(-tool_z[2], -1.0, 1.0))))  # tool z points down
    seated = depth >= LID_SEATED_M and tilt_deg < 2.0 and off_axis <= LID_RADIAL_PLAY_M + 0.0005
    return TaskProgress(
        "lid seated flat inside the lip (on the floor, tilt < 2 deg)", seated, depth, LID_SEATED_M, "m"
    )


SCENE = Scene(
    "lid",
    "A wide, shallow pan under a 200 mm lid with 2.5 mm of radial play; a seed puts the pan "
    "4 to 12 mm off the tool axis in a random direction (paper 2.3.9: offset d < d_max).",
    "lid.xml",
    "lid_tool.xml",
    HOME_TOOL_DOWN,
    "pan",
    0.0,
    _lid,
    offset_range_m=(0.004, 0.012),
)

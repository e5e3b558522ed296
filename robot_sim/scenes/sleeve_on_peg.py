"""Sleeve on peg (paper 2.3.5, Table 3)."""

from typing import TYPE_CHECKING

from robot_sim.scenes.base import HOME_TOOL_DOWN, Scene, TaskProgress

if TYPE_CHECKING:
    from robot_sim.sim import Simulation


def sleeve_insertion_depth(sim: "Simulation") -> float:
    """Peg top past the sleeve mouth, along the sleeve axis [m] (negative: not yet over it)."""
    peg_top = sim.data.site_xpos[sim.model.site("peg_top").id]
    R_world_port = sim.data.site_xmat[sim.layout.port_site].reshape(3, 3)
    return float(R_world_port[:, 2] @ (sim.controller.p_world_port - peg_top))


def _sleeve_on_peg(sim: "Simulation") -> TaskProgress:
    depth = sleeve_insertion_depth(sim)
    return TaskProgress("sleeve over the peg, insertion depth >= 30 mm", depth >= 0.030, depth, 0.030, "m")


SCENE = Scene(
    "sleeve_on_peg",
    "A 25.4 mm peg with a 1.5 mm chamfer under a sleeve of 0.089 mm diametral clearance "
    "(the paper's 1.0035 in over 1 in); a seed moves the peg up to 1 mm in x and y.",
    "sleeve_on_peg.xml",
    "sleeve.xml",
    HOME_TOOL_DOWN,
    "peg_base",
    0.001,
    _sleeve_on_peg,
)

"""Socket wrench insertion (paper 2.3.10, Fig. 13): a square shank with an off-axis,
spring-loaded detent ball into a square socket."""

from typing import TYPE_CHECKING

from robot_sim.scenes.base import HOME_TOOL_DOWN, Scene, TaskProgress, port_depth_below_m

if TYPE_CHECKING:
    from robot_sim.sim import Simulation

INSERTED_M = 0.018  # tip this far below the socket's top: the shank's 20 mm nearly all in


def _socket_wrench(sim: "Simulation") -> TaskProgress:
    depth = port_depth_below_m(sim, "socket_top")  # the shank's tip below the socket's top
    return TaskProgress(
        "shank fully inserted (tip >= 18 mm below the socket's top)",
        depth >= INSERTED_M,
        depth,
        INSERTED_M,
        "m",
    )


SCENE = Scene(
    "socket_wrench",
    "A 3/8 in square socket under a square shank with a spring-loaded detent ball, 0.25 mm of "
    "clearance a side; a seed moves the socket up to 0.4 mm in x and y (paper 2.3.10).",
    "socket_wrench.xml",
    "socket_shank.xml",
    HOME_TOOL_DOWN,
    "socket",
    0.0004,
    _socket_wrench,
)

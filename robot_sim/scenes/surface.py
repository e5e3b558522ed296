"""A rigid plate under the probe: press on it."""

from typing import TYPE_CHECKING

from robot_sim.scenes.base import HOME_TOOL_DOWN, Scene, TaskProgress

if TYPE_CHECKING:
    from robot_sim.sim import Simulation


def _press_surface(sim: "Simulation") -> TaskProgress:
    force_z = float(sim.controller.w_world_env_on_port[2])  # plate pushes up on the tool
    ok = 5.0 <= force_z <= 20.0
    return TaskProgress("steady press on the plate, normal force 5 to 20 N", ok, force_z, 5.0, "N")


SCENE = Scene(
    "surface",
    "A rigid plate under the probe tool (top face at z = 0.220 m).",
    "surface.xml",
    "probe.xml",
    HOME_TOOL_DOWN,
    "plate_body",
    0.003,
    _press_surface,
)

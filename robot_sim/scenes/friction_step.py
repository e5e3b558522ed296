"""A plate with a smooth part, a rough part and a ridge: slides for the force task monitor."""

from typing import TYPE_CHECKING

from robot_sim.scenes.base import HOME_TOOL_DOWN, Scene, TaskProgress

if TYPE_CHECKING:
    from robot_sim.sim import Simulation

SEAM_Y_M = 0.030  # smooth (mu 0.3) below, rough (mu 0.6) above; see the MJCF
RIDGE_Y_M = -0.060  # centre of the 6 mm ridge (6 mm wide)
MU_SMOOTH = 0.3
MU_ROUGH = 0.6


def _pressed_on_rough(sim: "Simulation") -> TaskProgress:
    force_z = float(sim.controller.w_world_env_on_port[2])
    on_rough = float(sim.controller.p_world_port[1]) > SEAM_Y_M
    ok = on_rough and 2.0 <= force_z <= 30.0
    return TaskProgress("the tip pressed (2 to 30 N) on the rough part (y > 30 mm)", ok, force_z, 2.0, "N")


SCENE = Scene(
    "friction_step",
    "The surface plate in two parts: smooth (mu 0.3) for y < 30 mm, rough (mu 0.6) beyond, and a "
    "6 mm ridge at y = -60 mm: slides for the force task monitor.",
    "friction_step.xml",
    "probe.xml",
    HOME_TOOL_DOWN,
    "plate_body",
    0.0,
    _pressed_on_rough,
)

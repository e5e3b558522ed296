"""Pneumatic quick-disconnect (paper 2.3.6): a snap fit that latches at 25-30 N."""

from collections.abc import Callable
from typing import TYPE_CHECKING

import mujoco

from robot_sim.scenes.base import HOME_TOOL_DOWN, Scene, TaskProgress

if TYPE_CHECKING:
    from robot_sim.sim import Simulation


LATCH_STROKE_M = 0.0035  # quick_connect: collar travel at which the latch catches


def _quick_connect_latch(model: mujoco.MjModel) -> Callable[[mujoco.MjData], None]:
    """Catch the latch once the collar has been pushed through its stroke (25-29.4 N of spring
    preload); the `latch` equality then holds the collar there, as the real coupling's balls do."""
    latch = model.equality("latch").id
    collar = model.jnt_qposadr[model.joint("collar_slide").id]

    def tick(data: mujoco.MjData) -> None:
        if not data.eq_active[latch] and data.qpos[collar] >= LATCH_STROKE_M:
            data.eq_active[latch] = 1

    return tick


def _quick_connect(sim: "Simulation") -> TaskProgress:
    travel = float(sim.data.qpos[sim.model.jnt_qposadr[sim.model.joint("collar_slide").id]])
    latched = bool(sim.data.eq_active[sim.model.equality("latch").id])
    return TaskProgress(
        "coupling latched (collar pushed 3.5 mm, 25-30 N)", latched, travel, LATCH_STROKE_M, "m"
    )


SCENE = Scene(
    "quick_connect",
    "The female half of a pneumatic quick-disconnect under the male plug; latching takes "
    "25-30 N (paper 2.3.6); a seed moves the receptacle up to 2 mm in x and y.",
    "quick_connect.xml",
    "male_coupling.xml",
    HOME_TOOL_DOWN,
    "receptacle",
    0.002,
    _quick_connect,
    _quick_connect_latch,
)

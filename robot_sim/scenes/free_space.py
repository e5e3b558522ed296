"""The arm alone with a probe tool and a goal marker to reach."""

from typing import TYPE_CHECKING

import numpy as np

from robot_sim.scenes.base import HOME_TOOL_DOWN, Scene, TaskProgress

if TYPE_CHECKING:
    from robot_sim.sim import Simulation


def _reach_goal(sim: "Simulation") -> TaskProgress:
    goal = sim.data.site_xpos[sim.model.site("goal").id]
    dist = float(np.linalg.norm(sim.controller.p_world_port - goal))
    return TaskProgress("port within 5 mm of the goal marker", dist <= 0.005, dist, 0.005, "m")


SCENE = Scene(
    "free_space",
    "The arm alone with a probe tool; a goal marker to reach.",
    "free_space.xml",
    "probe.xml",
    HOME_TOOL_DOWN,
    None,
    0.0,
    _reach_goal,
)

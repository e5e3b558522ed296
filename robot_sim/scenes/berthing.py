"""Berthing (paper 2.3.1, Fig. 3): a heavy sled on a frictionless plane, gripped off its centre of
gravity, to be pressed onto two posts so both its clamps seat."""

import math
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from robot_sim.scenes.base import HOME_TOOL_DOWN, Scene, TaskProgress
from robot_sim.scenes.grasp import GripperSpec, held_from_start

if TYPE_CHECKING:
    from robot_sim.sim import Simulation

SEATED_M = 0.002  # each post within this of its clamp's seat
SQUARE_RAD = math.radians(1.0)  # and the sled within this of the posts' line
SIDEWAYS_M = (0.003, 0.009)  # a seed's sideways offset of the posts, either way
NEARER_M = 0.005  # and up to this nearer or further
TURN_RAD = math.radians(0.5)  # and turned up to this


def _posts_misplaced(model: mujoco.MjModel, rng: np.random.Generator) -> None:
    posts = model.body("posts")
    posts.pos[0] += rng.uniform(-NEARER_M, NEARER_M)
    posts.pos[1] += rng.choice([-1.0, 1.0]) * rng.uniform(*SIDEWAYS_M)
    mujoco.mju_axisAngle2Quat(posts.quat, np.array([0.0, 0.0, 1.0]), rng.uniform(-TURN_RAD, TURN_RAD))


def seat_errors_m(sim: "Simulation") -> tuple[float, float]:
    """[m] each post's centre from its clamp's seat, in the plane."""
    m, d = sim.model, sim.data
    return tuple(  # type: ignore[return-value]
        float(
            np.linalg.norm((d.site_xpos[m.site(f"post_{c}").id] - d.site_xpos[m.site(f"seat_{c}").id])[0:2])
        )
        for c in ("a", "b")
    )


def _berthing(sim: "Simulation") -> TaskProgress:
    m, d = sim.model, sim.data
    errors = seat_errors_m(sim)
    sled_x = d.xmat[m.body("satellite").id].reshape(3, 3)[:, 0]
    posts_x = d.xmat[m.body("posts").id].reshape(3, 3)[:, 0]
    squareness = math.acos(float(np.clip(sled_x @ posts_x, -1.0, 1.0)))
    seated = max(errors) <= SEATED_M and squareness <= SQUARE_RAD
    return TaskProgress(
        "both clamps seated on their posts (within 2 mm, 1 deg)",
        seated,
        max(errors),
        SEATED_M,
        "m",
        at_most=True,
    )


SCENE = Scene(
    "berthing",
    "A 20 kg sled on a frictionless plane (x, y, yaw), gripped 130 mm off its centre of gravity, "
    "to be pressed onto two posts so both V clamps seat (paper 2.3.1); a seed moves the posts "
    "3-9 mm sideways, +-5 mm nearer and turns them up to 0.5 deg. Use the planar preset.",
    "berthing.xml",
    "gripper.xml",
    HOME_TOOL_DOWN,
    None,
    0.0,
    _berthing,
    held_from_start("grasp"),
    randomise=_posts_misplaced,
    gripper=GripperSpec(weld="grasp", grasp_site="handle_grasp", held_from_start=True),
)

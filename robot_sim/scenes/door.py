"""Opening and closing a latched door (paper 2.3.8, Fig. 11): a hinged door whose latch is
withdrawn by turning its knob; the gripper holds the knob from the start."""

import math
from collections.abc import Callable
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from robot_sim.scenes.base import HOME_TOOL_DOWN, Scene, TaskProgress
from robot_sim.scenes.grasp import GripperSpec, held_from_start

if TYPE_CHECKING:
    from robot_sim.sim import Simulation

RELEASE_RAD = math.radians(20.0)  # knob turn that withdraws the latch
RELATCH_KNOB_RAD = math.radians(10.0)  # the latch springs back out below this
SHUT_RAD = math.radians(0.5)  # door angle that counts as shut
OPENED_RAD = math.radians(45.0)  # what the task asks
HINGE_TO_KNOB_M = (0.100, 0.130)  # a seed's range
# data.userdata: what the task remembers (MuJoCo resets it with the data)
RELEASED, MAX_OPEN = 0, 1


def _angle(model: mujoco.MjModel, data: mujoco.MjData, joint: str) -> float:
    return float(data.qpos[model.jnt_qposadr[model.joint(joint).id]])


def _latch(model: mujoco.MjModel) -> Callable[[mujoco.MjData], None]:
    """The latch: withdrawn while the knob is turned 20 degrees; once the door is shut and the
    knob let back, it catches again (the `latch` equality holds the hinge at 0)."""
    latch = model.equality("latch").id
    hold_at_start = held_from_start("grasp")(model)
    knob_adr, door_adr = (model.jnt_qposadr[model.joint(j).id] for j in ("knob_turn", "door_hinge"))

    def tick(data: mujoco.MjData) -> None:
        hold_at_start(data)
        knob, door = data.qpos[knob_adr], data.qpos[door_adr]
        if data.eq_active[latch] and knob >= RELEASE_RAD:
            data.eq_active[latch] = 0
            data.userdata[RELEASED] = 1.0
        elif not data.eq_active[latch] and door <= SHUT_RAD and knob < RELATCH_KNOB_RAD:
            data.eq_active[latch] = 1
        data.userdata[MAX_OPEN] = max(data.userdata[MAX_OPEN], door)

    return tick


def _hinge_from_knob(model: mujoco.MjModel, rng: np.random.Generator) -> None:
    """Seeded: the hinge 100-130 mm from the knob; the knob (the grasp) stays where it is."""
    radius = rng.uniform(*HINGE_TO_KNOB_M)
    model.body("door").pos[0] = -radius
    model.body("handle").pos[0] = radius


def _door(sim: "Simulation") -> TaskProgress:
    m, d = sim.model, sim.data
    latched = bool(d.eq_active[m.equality("latch").id])
    opened = float(d.userdata[MAX_OPEN])
    done = bool(d.userdata[RELEASED]) and opened >= OPENED_RAD and latched
    return TaskProgress(
        "latch released, door opened >= 45 deg, then shut and latched",
        done,
        math.degrees(opened),
        math.degrees(OPENED_RAD),
        "deg",
    )


def door_angle_rad(sim: "Simulation") -> float:
    return _angle(sim.model, sim.data, "door_hinge")


SCENE = Scene(
    "door",
    "A small latched hatch held by its knob (the gripper's grasp); turn the knob to withdraw the "
    "latch, swing it open 45 deg or more about its hinge, shut it (paper 2.3.8); a seed puts the "
    "hinge 100-130 mm from the knob.",
    "door.xml",
    "gripper.xml",
    HOME_TOOL_DOWN,
    None,
    0.0,
    _door,
    _latch,
    randomise=_hinge_from_knob,
    gripper=GripperSpec(weld="grasp", grasp_site="knob_grasp", held_from_start=True),
)

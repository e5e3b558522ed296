"""The stowage bay both tool tasks use (paper 2.3.2, Fig. 4; assets/scenes/tool_bay.xml): its
spring-loaded bayonet lock, the gripper that catches the tool, and what the bay can tell."""

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from robot_sim.scenes.grasp import GripperSpec

if TYPE_CHECKING:
    from robot_sim.sim import Simulation

LOCK_SPRING_NM_PER_RAD = 0.6
LOCK_DAMPING_NMS_PER_RAD = 0.02
IN_LOCK_M = 0.016  # the legs are in the lock (at or under the tabs' top) below this lift
LOCKED_RAD = 0.15  # turned less than this, bottomed legs are under the tabs
BOTTOMED_M = 0.001
OUT_M = 0.040  # the legs well clear of the bay's 40 mm walls' tabs: out
GRIPPER = GripperSpec(weld="grasp", grasp_site="tool_grasp", round_about_axis=True)  # a round knob


@dataclass(frozen=True)
class Bay:
    """The bay and its tool in a loaded model (ids looked up once: the lock runs every tick)."""

    floor: int  # site
    foot: int  # site: the tool's foot
    bay: int  # body
    tool: int  # body
    grasp: int  # equality: the gripper's weld on the tool

    @classmethod
    def of(cls, model: mujoco.MjModel) -> "Bay":
        site, body = model.site, model.body
        grasp = model.equality(GRIPPER.weld).id
        return cls(site("bay_floor").id, site("tool_base").id, body("bay").id, body("stow_tool").id, grasp)

    def held(self, data: mujoco.MjData) -> bool:
        """The tool is in the gripper."""
        return bool(data.eq_active[self.grasp])

    def out(self, data: mujoco.MjData) -> bool:
        """Retrieved: the tool out of the bay (foot >= OUT_M up) in the gripper."""
        return self.lift_m(data) >= OUT_M and self.held(data)

    def stowed(self, data: mujoco.MjData) -> bool:
        """Stowed: the tool bottomed, locked (legs under the tabs) and let go."""
        return (
            self.lift_m(data) <= BOTTOMED_M and abs(self.turn_rad(data)) <= LOCKED_RAD and not self.held(data)
        )

    def lift_m(self, data: mujoco.MjData) -> float:
        """[m] the tool's foot above the bay's floor."""
        return float(data.site_xpos[self.foot][2] - data.site_xpos[self.floor][2])

    def turn_rad(self, data: mujoco.MjData) -> float:
        """The tool's turn about the vertical from its locked angle (the bay's axes), (-pi, pi]."""
        R_bay_tool = data.xmat[self.bay].reshape(3, 3).T @ data.xmat[self.tool].reshape(3, 3)
        return float(math.atan2(R_bay_tool[1, 0], R_bay_tool[0, 0]))


def lock_spring(model: mujoco.MjModel) -> Callable[[mujoco.MjData], None]:
    """The lock's spring turns the legs back under the tabs while they are in the lock: a torque
    about the vertical on the tool, proportional to its turn (and a little damping)."""
    bay = Bay.of(model)
    dof = model.jnt_dofadr[model.body_jntadr[bay.tool]]  # freejoint: 3 linear, then 3 angular (local)
    torque = np.zeros(3)

    def tick(data: mujoco.MjData) -> None:
        torque[2] = 0.0
        if bay.lift_m(data) < IN_LOCK_M:
            spin = float(data.xmat[bay.tool].reshape(3, 3)[2] @ data.qvel[dof + 3 : dof + 6])  # world z rate
            torque[2] = -LOCK_SPRING_NM_PER_RAD * bay.turn_rad(data) - LOCK_DAMPING_NMS_PER_RAD * spin
        data.xfrc_applied[bay.tool, 3:6] = torque

    return tick


def held(sim: "Simulation") -> bool:
    return Bay.of(sim.model).held(sim.data)


BAY_JITTER_M = 0.002  # a seed moves the bay up to this in x and y


def bay_moved(with_tool: bool) -> Callable[[mujoco.MjModel, np.random.Generator], None]:
    """Seeded: the bay (and the tool in it, `with_tool`) up to 2 mm off in x and y."""

    def randomise(model: mujoco.MjModel, rng: np.random.Generator) -> None:
        offset = rng.uniform(-BAY_JITTER_M, BAY_JITTER_M, 2)
        model.body("bay").pos[0:2] += offset
        if with_tool:
            model.qpos0[tool_qpos(model) : tool_qpos(model) + 2] += offset

    return randomise


def tool_qpos(model: mujoco.MjModel) -> int:
    """Where the tool's free joint starts in qpos (x, y, z, then the quaternion)."""
    return int(model.jnt_qposadr[model.body_jntadr[model.body("stow_tool").id]])

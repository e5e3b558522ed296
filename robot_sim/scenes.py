"""Task scenes: which fixtures, which tool, where the arm starts, and what counts as success.

Each scene is an MJCF under assets/scenes plus a success predicate evaluated on the running
simulation. A seed jitters the fixture's position (a few mm in x and y) so that experiments can
vary the task; no seed gives the nominal layout.
"""

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from robot_sim.errors import UnknownNameError

if TYPE_CHECKING:
    from robot_sim.sim import Simulation

# Tool pointing straight down with the wrist well away from singularities: pitch joints
# 2, 3 and 5 sum to pi/2.
HOME_TOOL_DOWN = (0.0, 0.3, 0.2, 0.0, math.pi / 2 - 0.5, 0.0)


@dataclass(frozen=True)
class TaskProgress:
    """A scene's success predicate, evaluated now."""

    predicate: str  # what success means, in words
    success: bool
    progress: float  # the measured quantity, in `unit`
    target: float
    unit: str


@dataclass(frozen=True)
class Scene:
    name: str
    description: str
    scene_file: str
    tool_file: str
    home_qpos: tuple[float, ...]
    fixture_body: str | None  # moved by a seed (see fixture_offset)
    jitter_m: float
    predicate: "Callable[[Simulation], TaskProgress]"
    # A fixture's own logic, bound to the loaded model and run every control tick: what MJCF
    # cannot say (a latch that catches and stays caught).
    mechanism: Callable[[mujoco.MjModel], Callable[[mujoco.MjData], None]] | None = None
    # (min, max) [m]: a seed puts the fixture this far off its place in a random direction
    # (when the task needs a real misalignment); otherwise anywhere within +-jitter_m in x, y.
    offset_range_m: tuple[float, float] | None = None


def fixture_offset(scene: Scene, rng: np.random.Generator) -> np.ndarray:
    """[m] (dx, dy) a seed moves the scene's fixture by: the one place the seeded layouts live."""
    if scene.offset_range_m is not None:
        distance, heading = rng.uniform(*scene.offset_range_m), rng.uniform(0.0, 2.0 * math.pi)
        return distance * np.array([math.cos(heading), math.sin(heading)])
    return rng.uniform(-scene.jitter_m, scene.jitter_m, 2)


def _reach_goal(sim: "Simulation") -> TaskProgress:
    goal = sim.data.site_xpos[sim.model.site("goal").id]
    dist = float(np.linalg.norm(sim.controller.p_world_port - goal))
    return TaskProgress("port within 5 mm of the goal marker", dist <= 0.005, dist, 0.005, "m")


def _press_surface(sim: "Simulation") -> TaskProgress:
    force_z = float(sim.controller.w_world_env_on_port[2])  # plate pushes up on the tool
    ok = 5.0 <= force_z <= 20.0
    return TaskProgress("steady press on the plate, normal force 5 to 20 N", ok, force_z, 5.0, "N")


def sleeve_insertion_depth(sim: "Simulation") -> float:
    """Peg top past the sleeve mouth, along the sleeve axis [m] (negative: not yet over it)."""
    peg_top = sim.data.site_xpos[sim.model.site("peg_top").id]
    R_world_port = sim.data.site_xmat[sim.layout.port_site].reshape(3, 3)
    return float(R_world_port[:, 2] @ (sim.controller.p_world_port - peg_top))


def _sleeve_on_peg(sim: "Simulation") -> TaskProgress:
    depth = sleeve_insertion_depth(sim)
    return TaskProgress("sleeve over the peg, insertion depth >= 30 mm", depth >= 0.030, depth, 0.030, "m")


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


SCENES: dict[str, Scene] = {
    s.name: s
    for s in (
        Scene(
            "free_space",
            "The arm alone with a probe tool; a goal marker to reach.",
            "free_space.xml",
            "probe.xml",
            HOME_TOOL_DOWN,
            None,
            0.0,
            _reach_goal,
        ),
        Scene(
            "surface",
            "A rigid plate under the probe tool (top face at z = 0.220 m).",
            "surface.xml",
            "probe.xml",
            HOME_TOOL_DOWN,
            "plate_body",
            0.003,
            _press_surface,
        ),
        Scene(
            "sleeve_on_peg",
            "A 25.4 mm peg with a 1.5 mm chamfer under a sleeve of 0.089 mm diametral clearance "
            "(the paper's 1.0035 in over 1 in); a seed moves the peg up to 1 mm in x and y.",
            "sleeve_on_peg.xml",
            "sleeve.xml",
            HOME_TOOL_DOWN,
            "peg_base",
            0.001,
            _sleeve_on_peg,
        ),
        Scene(
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
        ),
        Scene(
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
        ),
    )
}


def get_scene(name: str) -> Scene:
    try:
        return SCENES[name]
    except KeyError:
        raise UnknownNameError("scene", name, list(SCENES)) from None

"""What a task scene is: fixtures and tool (MJCF), where the arm starts, a success predicate,
optional fixture logic, and how a seed misaligns the fixture."""

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from robot_sim.scenes.grasp import GripperSpec

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
    at_most: bool = False  # success wants `progress` at or below `target` (an error to shrink)


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
    # [m] (x, y): a seed's offset is drawn within +-these instead (a misalignment along one
    # axis only); overrides jitter_m.
    offset_box_m: tuple[float, float] | None = None
    # A seed's layout when moving one body is not enough (the door's hinge about its knob);
    # replaces the fixture offset.
    randomise: Callable[[mujoco.MjModel, np.random.Generator], None] | None = None
    # The tool's gripper, if it has one: what `gripper` commands close on.
    gripper: GripperSpec | None = None
    # Applied to every fresh model before a seed's layout: a start that the MJCF file shared
    # with another scene does not say (the stowed tool already in the gripper).
    prepare: Callable[[mujoco.MjModel], None] | None = None


def port_depth_below_m(sim: "Simulation", site: str) -> float:
    """[m] how far the port is below `site` along the base z (negative: above it)."""
    return float(sim.data.site_xpos[sim.model.site(site).id][2] - sim.controller.p_world_port[2])


def apply_seed(scene: Scene, model: mujoco.MjModel, seed: int | None) -> None:
    """Lay out `model` (freshly built, not yet simulated) as `seed` says; None: nominal."""
    if scene.prepare is not None:
        scene.prepare(model)
    if seed is None:
        return
    rng = np.random.default_rng(seed)
    if scene.randomise is not None:
        scene.randomise(model, rng)
    elif scene.fixture_body is not None:
        model.body(scene.fixture_body).pos[0:2] += fixture_offset(scene, rng)


def fixture_offset(scene: Scene, rng: np.random.Generator) -> np.ndarray:
    """[m] (dx, dy) a seed moves the scene's fixture by: the one place the seeded layouts live."""
    if scene.offset_range_m is not None:
        distance, heading = rng.uniform(*scene.offset_range_m), rng.uniform(0.0, 2.0 * math.pi)
        return distance * np.array([math.cos(heading), math.sin(heading)])
    half = scene.offset_box_m or (scene.jitter_m, scene.jitter_m)
    return rng.uniform(-np.array(half), np.array(half))

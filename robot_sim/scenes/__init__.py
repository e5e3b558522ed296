"""Task scenes: which fixtures, which tool, where the arm starts, and what counts as success.

One module per scene: its MJCF under assets/scenes plus a success predicate evaluated on the
running simulation, and a seeded misalignment of the fixture (base.fixture_offset); no seed
gives the nominal layout.
"""

from robot_sim.errors import UnknownNameError
from robot_sim.scenes import (
    berthing,
    door,
    free_space,
    friction_step,
    lid,
    plug,
    quick_connect,
    sleeve_on_peg,
    socket_wrench,
    surface,
    tool_exchange,
    tool_retrieval,
    tool_stowage,
)
from robot_sim.scenes.base import HOME_TOOL_DOWN, Scene, TaskProgress, apply_seed, fixture_offset
from robot_sim.scenes.quick_connect import LATCH_STROKE_M
from robot_sim.scenes.sleeve_on_peg import sleeve_insertion_depth

SCENES: dict[str, Scene] = {
    m.SCENE.name: m.SCENE
    for m in (
        free_space,
        surface,
        sleeve_on_peg,
        quick_connect,
        lid,
        plug,
        socket_wrench,
        door,
        berthing,
        tool_retrieval,
        tool_stowage,
        tool_exchange,
        friction_step,
    )
}


def get_scene(name: str) -> Scene:
    try:
        return SCENES[name]
    except KeyError:
        raise UnknownNameError("scene", name, list(SCENES)) from None


__all__ = [
    "HOME_TOOL_DOWN",
    "LATCH_STROKE_M",
    "SCENES",
    "Scene",
    "TaskProgress",
    "apply_seed",
    "fixture_offset",
    "get_scene",
    "sleeve_insertion_depth",
]

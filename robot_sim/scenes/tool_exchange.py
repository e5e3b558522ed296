"""Tool exchange (paper 2.3.2: "100 consecutive trials of both retrieval and stowage without a
single failure"): the retrieval's scene, run as one simulation with no reset while the machine
retrieves, carries, stows and starts again.

What counts is what the bay saw, not what the machine says: a witness (the scene's mechanism,
beside the lock's spring) counts whole exchanges, the tool out in the gripper (its foot >= 40 mm
up) and then stowed (bottomed, locked, let go). The predicate holds with the paper's 100 whole
exchanges seen and the tool stowed now; its progress is the count. A machine asked for fewer
cycles, or one that fails on the 57th, has made progress, not the task.
"""

from dataclasses import replace
from typing import TYPE_CHECKING

import mujoco

from robot_sim.scenes.base import TaskProgress
from robot_sim.scenes.tool_bay import Bay, lock_spring
from robot_sim.scenes.tool_retrieval import SCENE as RETRIEVAL

if TYPE_CHECKING:
    from robot_sim.sim import Simulation

LOOK_EVERY_TICKS = 20  # the witness looks at 50 Hz: a tool is out or stowed for seconds
EXCHANGES_WANTED = 100  # the paper's "100 consecutive trials of both retrieval and stowage"


class ExchangeWitness:
    """The lock's spring, and a count of the exchanges the bay has seen since the load."""

    def __init__(self, model: mujoco.MjModel) -> None:
        self._spring = lock_spring(model)
        self.bay = Bay.of(model)
        self._ticks = 0
        self.out = False  # the tool left the bay in the gripper, and is not stowed again yet
        self.exchanges = 0

    def __call__(self, data: mujoco.MjData) -> None:
        self._spring(data)
        self._ticks += 1
        if self._ticks % LOOK_EVERY_TICKS:
            return
        if not self.out:
            self.out = self.bay.out(data)
        elif self.bay.stowed(data):
            self.out = False
            self.exchanges += 1


def _exchanged(sim: "Simulation") -> TaskProgress:
    witness = sim.mechanism
    assert isinstance(witness, ExchangeWitness)
    return TaskProgress(
        f"{EXCHANGES_WANTED} whole exchanges seen by the bay (out in the gripper, then stowed, locked, "
        "let go), the tool stowed now",
        witness.exchanges >= EXCHANGES_WANTED and witness.bay.stowed(sim.data),
        witness.exchanges,
        EXCHANGES_WANTED,
        "exchanges",
    )


SCENE = replace(
    RETRIEVAL,
    name="tool_exchange",
    description=(
        "The tool locked in its stowage bay, its knob 20 mm under the open gripper (paper 2.3.2): "
        "retrieve it, carry it to a parking pose and back, stow it, again and again in one "
        "simulation; a seed moves the bay up to 2 mm in x and y."
    ),
    predicate=_exchanged,
    mechanism=ExchangeWitness,
)

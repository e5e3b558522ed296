"""Benchmark: the 1 kHz admittance loop with 1 ms physics, against bare mj_step.

Prints JSON: {"raw_step_hz", "free": {"rtf", "ratio_to_raw", ...}, "contact": {...}}. `rtf` is
sim seconds per wall second on one core; `ratio_to_raw` is the loop's cost per physics step over
a bare Python loop of mj_step on the same model, measured in the same run (machines are noisy,
ratios less so): the loop as sweeps, twins and previews run it (`Simulation.advance`, many ticks
a call). `step_ratio_to_raw` is the same for one `Simulation.step()` call per tick (a script's
way). Each ratio is the median over REPEATS rounds of the round's own ratio, the three measured
in turn from the same state in each round; the times are the best round's.
Before the tick was compiled (issue 30) the loop was one Python `step()` a tick.

    python -m bench.sim [--seconds 1]
"""

import argparse
import json
import statistics
import time
from collections.abc import Callable

import mujoco
import numpy as np

from robot_sim.behaviors.ptwl import Ptwl
from robot_sim.params import PtwlParams
from robot_sim.sim import Simulation

REPEATS = 9
# MuJoCo's whole integration state (time, qpos, qvel, act, ctrl, warm start, ...): every
# measurement of a round starts from the same one, so the three see the same contacts.
STATE = mujoco.mjtState.mjSTATE_INTEGRATION


class Snapshot:
    """The simulation's state (MuJoCo's and the controller's), to start each measurement from."""

    def __init__(self, sim: Simulation) -> None:
        self.sim = sim
        self.state = np.zeros(mujoco.mj_stateSize(sim.model, STATE))
        mujoco.mj_getState(sim.model, sim.data, self.state, STATE)
        self.f, self.i = sim.controller.f.copy(), sim.controller.i.copy()

    def restore(self) -> None:
        sim = self.sim
        mujoco.mj_setState(sim.model, sim.data, self.state, STATE)
        mujoco.mj_forward(sim.model, sim.data)
        sim.controller.f[:], sim.controller.i[:] = self.f, self.i


def raw_step_seconds(sim: Simulation, steps: int) -> float:
    """Wall time per bare mj_step of the same model and state (a Python loop)."""
    model, data = sim.model, sim.data
    t0 = time.perf_counter()
    for _ in range(steps):
        mujoco.mj_step(model, data)
    return (time.perf_counter() - t0) / steps


def loop_step_seconds(sim: Simulation, steps: int) -> float:
    """Wall time per tick of `Simulation.advance(steps)` (nothing ends in it: see the scenes)."""
    t0 = time.perf_counter()
    report, ran = sim.advance(steps)
    assert report is None and ran == steps
    return (time.perf_counter() - t0) / steps


def step_call_seconds(sim: Simulation, steps: int) -> float:
    """Wall time per `Simulation.step()` call."""
    t0 = time.perf_counter()
    for _ in range(steps):
        sim.step()
    return (time.perf_counter() - t0) / steps


def free_space_sim() -> Simulation:
    """PTWL sweeping in free space (behavior running every tick)."""
    sim = Simulation("free_space")
    sim.start(Ptwl(PtwlParams(translation=[0.1, 0.05, -0.05], rotation=[0.0, 0.3, 0.2], duration=600)))
    return sim


def contact_sim() -> Simulation:
    """PTWL pressing the probe 10 mm past the plate and holding (contact every tick)."""
    sim = Simulation("surface")
    overshoot_target = [0.0, 0.0, 0.0466 + 0.010]  # tool z points down: into the plate
    sim.start(Ptwl(PtwlParams(translation=overshoot_target, duration=1.0, force_threshold=100, watchdog=600)))
    sim.run(2.0)
    if sim.data.ncon == 0:
        raise RuntimeError("contact benchmark is not in contact")
    return sim


def measure(make: Callable[[], Simulation], steps: int) -> list[tuple[float, float, float]]:
    """Per round, (loop, step call, bare mj_step) [s] per tick: REPEATS rounds, each measuring
    the three in turn from the same state, back to back (a busy machine's slow spells, which
    last longer than a round, land on all three alike)."""
    sim = make()
    start = Snapshot(sim)
    rounds = []
    for _ in range(REPEATS):
        figures = []
        for how in (loop_step_seconds, step_call_seconds, raw_step_seconds):
            start.restore()
            figures.append(how(sim, steps))
        rounds.append((figures[0], figures[1], figures[2]))
    return rounds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=1.0, help="sim seconds per measurement")
    args = parser.parse_args()
    steps = int(args.seconds * 1000)
    result: dict[str, object] = {}
    raws = []
    for name, make in (("free", free_space_sim), ("contact", contact_sim)):
        rounds = measure(make, steps)
        loop, per_call, raw = (min(r[k] for r in rounds) for k in range(3))
        raws.append(raw)
        sim_dt = 0.001
        result[name] = {
            "rtf": round(sim_dt / loop, 1),
            "ratio_to_raw": round(statistics.median(r[0] / r[2] for r in rounds), 2),
            "step_ratio_to_raw": round(statistics.median(r[1] / r[2] for r in rounds), 2),
            "loop_us_per_tick": round(loop * 1e6, 2),
            "step_us_per_call": round(per_call * 1e6, 2),
            "raw_us_per_step": round(raw * 1e6, 2),
        }
    result = {"raw_step_hz": round(1.0 / min(raws)), **result}
    print(json.dumps(result))


if __name__ == "__main__":
    main()

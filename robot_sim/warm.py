"""The compiled tick (tick.py) loaded before anyone waits on it: numba compiles a function at
its first call, or loads it from its cache (`__pycache__` beside tick.py, or the user's cache
directory where that is read-only). Compiling takes seconds, once per install; loading ~0.3 s.
A robot server and a console call this at their start, so that no first command pays it."""

import time

from robot_sim.behaviors import behavior_for
from robot_sim.params import DitherParams, GripperParams, MonitorSpec, PtwlParams, RweParams
from robot_sim.sim import Simulation

# Short runs of every behavior kind: between them they call every compiled entry point.
_BEHAVIORS = (
    PtwlParams(translation=[0.0, 0.0, 0.002], duration=0.01, watchdog=0.05),
    DitherParams(duration=0.02, travel=0.001, watchdog=0.02, monitor=MonitorSpec()),
    RweParams(duration=0.005),
    GripperParams(action="open", duration=0.005),
)


def warm_up() -> float:
    """Load (or compile) the compiled tick; the seconds it took."""
    t0 = time.perf_counter()
    sim = Simulation("free_space")
    ctl = sim.controller
    ctl.measure()
    ctl.command()
    for params in _BEHAVIORS:
        sim.run_behavior(behavior_for(params), max_seconds=0.1)
    sim.start(behavior_for(_BEHAVIORS[0]))
    sim.step()
    sim.hold_position()
    return time.perf_counter() - t0

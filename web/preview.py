"""Preview before Send (issue 14, after IPSE's preview): run a contemplated command on a copy of
the robot model started where the ground twin puts the robot now, to its exit, and say where the
attractor and the port go, how it ends (goal reached, wrench breach, timeout) and its peak force.
Nothing is sent."""

import threading
import time
from dataclasses import dataclass

import numpy as np

from robot_sim.behaviors import BehaviorParams, behavior_for
from robot_sim.sim import UNBOUNDED_TICKS, Simulation
from web.twin import TwinPoint

SAMPLE_S = 0.02  # [s] sim time between path points
MAX_PREVIEW_S = 700.0  # a behavior's watchdog ends it well before (<= 600 s)


@dataclass(frozen=True)
class PreviewResult:
    exit: str
    duration_s: float  # [s] sim time from start to exit
    peak_force_n: float
    peak_torque_nm: float
    port_path: np.ndarray  # (n, 3) [m] base frame
    attractor_path: np.ndarray  # (n, 3) [m]
    compute_s: float  # [s] wall time it took


class Previewer:
    """One preview at a time; a model per scene, kept (building one costs more than most previews)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._sims: dict[str, Simulation] = {}

    def run(self, start: TwinPoint, params: BehaviorParams) -> PreviewResult:
        with self._lock:
            t0 = time.perf_counter()
            sim = self._sims.get(start.scene)
            if sim is None:
                sim = self._sims[start.scene] = Simulation(start.scene)
            sim.frames = start.frames
            sim.sync_to(start.sim_time, start.joint_positions, start.attractor, start.gains)
            sim.start(behavior_for(params))
            ctl = sim.controller
            ports, attractors = [ctl.p_world_port.copy()], [ctl.p_world_attractor.copy()]
            next_sample = sim.time + SAMPLE_S
            report = None
            end_s = start.sim_time + MAX_PREVIEW_S
            while report is None and sim.time < end_s:
                report, _ = sim.advance(UNBOUNDED_TICKS, min(next_sample, end_s))
                if sim.time >= next_sample or report is not None:
                    next_sample += SAMPLE_S
                    ports.append(ctl.p_world_port.copy())
                    attractors.append(ctl.p_world_attractor.copy())
            if report is None:
                report = sim.abort("preview ran out of time")
            assert report is not None
            return PreviewResult(
                report.exit.value,
                report.duration,
                report.peak_force,
                report.peak_torque,
                np.array(ports),
                np.array(attractors),
                time.perf_counter() - t0,
            )

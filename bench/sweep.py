"""Benchmark: virtual-time sweep trials per minute, on one worker and on every core, in one run.

Each trial is a sleeve-on-peg trial (the onboard state machine at RTT 0: about 12 s of sim
time); `per_10s_sim` scales the rate to the issue's 10 s trials. Prints JSON:
{"trial_sim_s", "workers", "one_worker": {...}, "all_workers": {...}, "speedup", "same_rows",
"physics_share", "per_10s_sim_physics_only"}: the last is the rate's ceiling were the Python
side free, set by MuJoCo's contact work (the sleeve's 16 walls about the peg, all within
0.3 mm of it once inserted).

    python -m bench.sweep [--trials 24]
"""

import argparse
import json
import os
import statistics
import time
from typing import Any

import mujoco

from experiments.sweep.backends import run_local
from experiments.sweep.spec import TrialSpec
from experiments.sweep.trial import simulate


def rate(specs: list[TrialSpec], workers: int) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    t0 = time.perf_counter()
    rows = list(run_local(specs, workers))
    wall = time.perf_counter() - t0
    sim_s = statistics.fmean(r["operator_time_s"] for r in rows)
    per_min = 60.0 * len(rows) / wall
    return {
        "trials": len(rows),
        "wall_s": round(wall, 2),
        "trials_per_min": round(per_min, 1),
        "per_10s_sim": round(per_min * sim_s / 10.0, 1),
    }, rows


def physics_share(spec: TrialSpec) -> float:
    """The part of one trial's wall time spent inside mj_step (MuJoCo's own timer): the rest is
    the Python controller, behaviors, link and operator. Rates above rate / share would need
    cheaper physics, whatever the Python side did."""
    t0 = time.perf_counter()
    trial = simulate(spec)
    wall = time.perf_counter() - t0
    step = trial.robot.sim.data.timer[mujoco.mjtTimer.mjTIMER_STEP]
    return step.duration / wall


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--trials", type=int, default=24)
    args = parser.parse_args()
    specs = [TrialSpec("sleeve_on_peg", "onboard", 0.0, 0.0, 0.0, seed) for seed in range(args.trials)]
    workers = os.cpu_count() or 1
    one, rows_one = rate(specs, 1)
    every, rows_every = rate(specs, workers)
    same = sorted(map(repr, rows_one)) == sorted(map(repr, rows_every))
    share = statistics.fmean(physics_share(spec) for spec in specs[:3])
    print(
        json.dumps(
            {
                "trial_sim_s": round(statistics.fmean(r["operator_time_s"] for r in rows_one), 2),
                "workers": workers,
                "one_worker": one,
                "all_workers": every,
                "speedup": round(every["trials_per_min"] / one["trials_per_min"], 2),
                "same_rows": same,
                "physics_share": round(share, 3),
                # The ceiling with a free controller: physics alone, on every worker.
                "per_10s_sim_physics_only": round(every["per_10s_sim"] / share, 1),
            }
        )
    )


if __name__ == "__main__":
    main()

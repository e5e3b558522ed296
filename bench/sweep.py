"""Benchmark: virtual-time sweep trials per minute, on one worker and on every core, in one run.

Each trial is a sleeve-on-peg trial (the onboard state machine at RTT 0: about 12 s of sim
time); `per_10s_sim` scales the rate to the issue's 10 s trials. Prints JSON:
{"trial_sim_s", "workers", "one_worker": {...}, "all_workers": {...}, "speedup", "same_rows",
"physics_share", "of_physics_ceiling", "per_10s_sim_physics_only", "without_wall_contact"}: the
one- and all-worker rates are the faster of two interleaved runs each; `of_physics_ceiling` is
the rate over the physics-only ceiling; `per_10s_sim_physics_only`
is the rate's ceiling were the Python side free, set by MuJoCo's contact work (the sleeve's 16
walls about the peg, all within 0.3 mm of it once inserted); `without_wall_contact` is the
rate's ceiling with a free sleeve contact model: the same trials with the walls' collisions
off (the sleeve slides down to its cap), their speed-up per second of sim time over the exact
trials measured on one worker in this run (best of three each, interleaved), applied to the
all-workers rate.

    python -m bench.sweep [--trials 24]
"""

import argparse
import json
import os
import statistics
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any
from unittest import mock

import mujoco

import robot_sim.sim
from ptwl.experiments.sweep.backends import run_local
from ptwl.experiments.sweep.spec import TrialSpec
from ptwl.experiments.sweep.trial import simulate


def rate(specs: list[TrialSpec], workers: int) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    t0 = time.perf_counter()
    rows = [row for row, _ in run_local(specs, workers)]
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


@contextmanager
def walls_without_contact() -> Iterator[None]:
    """Simulations built meanwhile have the sleeve's wall boxes out of collision (a what-if)."""
    build = robot_sim.sim.build_model

    def without_walls(scene_file: str, tool_file: str) -> mujoco.MjModel:
        model = build(scene_file, tool_file)
        cap = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "arm/tool/sleeve_cap")
        walls = (model.geom_bodyid == model.geom_bodyid[cap]) & (model.geom_type == mujoco.mjtGeom.mjGEOM_BOX)
        model.geom_contype[walls] = 0
        model.geom_conaffinity[walls] = 0
        return model

    with mock.patch.object(robot_sim.sim, "build_model", without_walls):
        yield


def wall_per_sim_s(specs: list[TrialSpec]) -> float:
    """[s/s] wall time per second of sim time, the trials run one after another here (a trial
    without wall contact may run a different length of sim time)."""
    t0 = time.perf_counter()
    sim_s = sum(simulate(spec).robot.sim.time for spec in specs)
    return (time.perf_counter() - t0) / sim_s


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--trials", type=int, default=24)
    args = parser.parse_args()
    specs = [TrialSpec("sleeve_on_peg", "onboard", 0.0, 0.0, 0.0, seed) for seed in range(args.trials)]
    workers = os.cpu_count() or 1
    # Interleaved, the faster of two each: a shared machine's speed swings by tens of percent.
    (one, rows_one), (every, rows_every) = rate(specs, 1), rate(specs, workers)
    one = max(one, rate(specs, 1)[0], key=lambda r: r["trials_per_min"])
    every = max(every, rate(specs, workers)[0], key=lambda r: r["trials_per_min"])
    same = sorted(map(repr, rows_one)) == sorted(map(repr, rows_every))
    share = statistics.fmean(physics_share(spec) for spec in specs[:3])
    # Interleaved, best of three: a shared machine's noise is +-25 % run to run here.
    exact_runs, free_runs = [], []
    for _ in range(3):
        exact_runs.append(wall_per_sim_s(specs[:4]))
        with walls_without_contact():
            free_runs.append(wall_per_sim_s(specs[:4]))
    exact, free = min(exact_runs), min(free_runs)
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
                # the rate over the physics-only ceiling below (issue 30's >= 0.85)
                "of_physics_ceiling": round(share, 3),
                # The ceiling with a free controller: physics alone, on every worker.
                "per_10s_sim_physics_only": round(every["per_10s_sim"] / share, 1),
                # The ceiling with a free sleeve contact model: the arm, controller, link and
                # operator alone.
                "without_wall_contact": {
                    "speedup_vs_exact": round(exact / free, 2),
                    "per_10s_sim": round(every["per_10s_sim"] * exact / free, 1),
                },
            }
        )
    )


if __name__ == "__main__":
    main()

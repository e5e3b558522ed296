"""Sleeve on peg (paper 2.3.5, Table 3) at the paper's 0.089 mm fit: aligned it takes one PTWL;
tilted 2-4 degrees it jams, and the documented twist-dither strategy recovers the jams."""

import functools
import math
import os
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest

from robot_sim.behaviors import ExitCondition, Ptwl, Rwe
from robot_sim.params import PtwlParams, RweParams
from robot_sim.policies import run_onboard
from robot_sim.policies.sleeve_on_peg import INSERT
from robot_sim.scenes import get_scene, sleeve_insertion_depth
from robot_sim.sim import Simulation

PEG_RADIUS_M = 0.0127


def test_the_fit_is_the_papers_and_home_is_on_the_peg_axis() -> None:
    sim = Simulation("sleeve_on_peg")
    m, d = sim.model, sim.data
    port = sim.controller.p_world_port
    walls = [g for g in range(m.ngeom) if m.geom(g).name == "" and m.geom_bodyid[g] == sim.layout.tool_body]
    walls = [g for g in walls if m.geom_type[g] == 6]  # boxes
    assert len(walls) == 16
    inner = [np.linalg.norm((d.geom_xpos[g] - port)[0:2]) - m.geom_size[g][0] for g in walls]
    diametral_clearance = 2 * (float(np.mean(inner)) - PEG_RADIUS_M)
    assert diametral_clearance == pytest.approx(0.0254 * 0.0035, abs=2e-6)  # 1.0035" bore, 1" peg
    peg_top = d.site_xpos[m.site("peg_top").id]
    assert np.linalg.norm((port - peg_top)[0:2]) < 5e-5


def test_aligned_insertion_is_one_ptwl_as_in_table_3() -> None:
    sim = Simulation("sleeve_on_peg")
    run = run_onboard("sleeve_on_peg", sim=sim)
    reports = [s.report for s in run.steps]
    assert [r.behavior for r in reports] == ["ptwl"] and run.end == "completed"
    assert reports[0].exit is ExitCondition.TIMEOUT  # pressing on the bottom, as the paper's 10 of 10
    assert 15.0 <= reports[0].peak_force <= 25.0  # paper: 18.8 N mean peak
    assert sim.task().success and sim.task().progress >= 0.039
    # Resting bottomed on the peg, the wrench reads steady (state machines read it as events).
    wrenches = np.array(
        [sim.controller.w_world_env_on_port.copy() for _ in range(2000) if sim.step() is None]
    )
    assert wrenches[:, 0:3].std(axis=0).max() < 0.5


@pytest.mark.parametrize("seed", [1, 2, 3, 4])
def test_every_jittered_peg_inserts_with_one_ptwl(seed: int) -> None:
    sim = Simulation("sleeve_on_peg", seed=seed)
    offset = sim.model.body("peg_base").pos[0:2] - Simulation("sleeve_on_peg").model.body("peg_base").pos[0:2]
    assert np.all(np.abs(offset) <= get_scene("sleeve_on_peg").jitter_m)
    run = run_onboard("sleeve_on_peg", sim=sim)
    assert len(run.steps) == 1 and run.success and run.end == "completed"


def tilted(axis: int, degrees: float) -> Simulation:
    sim = Simulation("sleeve_on_peg")
    rotation = [0.0, 0.0, 0.0]
    rotation[axis] = math.radians(degrees)
    assert (
        sim.run_behavior(Ptwl(PtwlParams(rotation=rotation, duration=1.0))).exit is ExitCondition.GOAL_REACHED
    )
    return sim


GRID = [(axis, sign * degrees) for axis in (0, 1) for degrees in (2, 3, 4) for sign in (1, -1)]


def grid_point(axis: int, degrees: float) -> tuple[str, bool, int, str, list[tuple[str, str, float, str]]]:
    """(the first PTWL's exit, inserted, behaviors used, the machine's end, and each step as
    (behavior, exit, duration [s], why)) for one tilt."""
    run = run_onboard("sleeve_on_peg", sim=tilted(axis, degrees))
    steps = [(s.report.behavior, s.report.exit.value, s.report.duration, s.why) for s in run.steps]
    return run.steps[0].report.exit.value, run.success, len(run.steps), run.end, steps


@functools.cache
def recovery_grid() -> dict[tuple[int, float], tuple[str, bool, int, str, list[tuple[str, str, float, str]]]]:
    """(axis, tilt [deg]) -> grid_point: each point is its own simulation, so they run on every
    core (the grid is most of this module's time)."""
    with ProcessPoolExecutor(max_workers=os.cpu_count()) as pool:
        results = pool.map(grid_point, *zip(*GRID, strict=True))
        return dict(zip(GRID, results, strict=True))


def test_tilts_of_2_to_4_degrees_jam_and_plain_ptwl_keeps_jamming() -> None:
    for (axis, degrees), (first_exit, *_) in recovery_grid().items():
        assert first_exit == "wrench_breach", (axis, degrees)
    sim = tilted(1, -3)
    assert sim.run_behavior(Ptwl(INSERT)).exit is ExitCondition.WRENCH_BREACH
    depth = sleeve_insertion_depth(sim)
    assert 0.0 < depth < 0.010  # caught at the mouth
    for _ in range(2):  # "jamming would still occur after a PTWL was sent" (paper 2.3.5)
        sim.run_behavior(Rwe(RweParams()))
        assert sim.run_behavior(Ptwl(INSERT)).exit is ExitCondition.WRENCH_BREACH
    assert sleeve_insertion_depth(sim) < depth + 0.002


def test_the_state_machine_recovers_at_least_9_of_10_jams_over_the_grid() -> None:
    outcome = recovery_grid()
    recovered = sum(success for _, success, _, _, _ in outcome.values())
    assert recovered >= 0.9 * len(outcome), outcome
    # It used the recovery (RWE, Dither, PTWL rounds), not luck on the first PTWL.
    assert all(used >= 4 for _, _, used, _, _ in outcome.values())
    # Its own verdict, from travel alone, agrees with the scene's predicate it never sees.
    assert all((end == "completed") == success for _, success, _, end, _ in outcome.values()), outcome


def test_each_recovery_phase_does_its_part() -> None:
    """Issue 29 point 5, over the grid. On main every "insert again" started from the push the
    twist left and 17 of 36 breached in their first 10 ms (28-33 N against 25 N), and 33 of 36
    twists ran to their 11 s watchdog: now a relief comes between, and a twist ends once the
    sleeve has given 4-5 mm."""
    steps = [step for *_, run in recovery_grid().values() for step in run]
    rounds = [i for i, (behavior, *_) in enumerate(steps) if behavior == "dither"]
    assert len(rounds) >= 24  # the grid's 12 tilts each need at least two rounds
    for i in rounds:  # relieve, twist, relieve, insert again: in that order, every round
        assert [b for b, *_ in steps[i - 1 : i + 3]] == ["rwe", "dither", "rwe", "ptwl"], steps[i - 1 : i + 3]
    inserts_again = [steps[i + 2] for i in rounds]
    assert all(duration >= 0.05 for _, _, duration, _ in inserts_again), inserts_again
    twists = [steps[i] for i in rounds]
    on_watchdog = [twist for twist in twists if twist[1] == "timeout"]
    assert len(on_watchdog) <= 0.2 * len(twists), on_watchdog  # 4 of 35 measured


def test_one_degree_is_absorbed_by_the_compliance() -> None:
    for axis in (0, 1):
        run = run_onboard("sleeve_on_peg", sim=tilted(axis, 1.0))
        assert len(run.steps) == 1 and run.success

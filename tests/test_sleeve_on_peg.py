"""Sleeve on peg (paper 2.3.5, Table 3) at the paper's 0.089 mm fit: aligned it takes one PTWL;
tilted 1-4 degrees it jams where the rigid fit would, and retracting and inserting again along
a new approach (paper 2.3.5) recovers the jams."""

import functools
import math
import os
import re
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest

from robot_sim.behaviors import ExitCondition, Ptwl, Rwe
from robot_sim.params import PtwlParams, RweParams
from robot_sim.policies import run_onboard
from robot_sim.policies.sleeve_on_peg import CHAMFER_M, INSERT, MOUTH_M
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
    # To the degree: the default orientation tolerance (20 mrad) would stop the turn 1.15 deg short.
    turn = PtwlParams(rotation=rotation, duration=1.0, orientation_tolerance=1e-3)
    assert sim.run_behavior(Ptwl(turn)).exit is ExitCondition.GOAL_REACHED
    assert tilt_deg(sim) == pytest.approx(abs(degrees), abs=0.1)
    return sim


def tilt_deg(sim: Simulation) -> float:
    """[deg] the sleeve's axis from the peg's (vertical)."""
    z_port = sim.data.site_xmat[sim.layout.port_site].reshape(3, 3)[:, 2]
    return math.degrees(math.acos(min(1.0, -float(z_port[2]))))


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
    """Issue 29 points 1 and 5, over the grid. With the fit as stiff as the rigid one, the
    paper's twist-dither no longer walked a wedged sleeve in (4 of 12 tilts recovered, most
    twists ran to their 11 s watchdog): each round now relieves, backs out with a dither that
    ends on its 4 mm of progress, turns the approach the way the jam's torque pushed, and
    inserts again."""
    steps = [step for *_, run in recovery_grid().values() for step in run]
    rounds = [i for i, (behavior, *_) in enumerate(steps) if behavior == "dither"]
    assert len(rounds) >= 12  # every tilt jams at least once
    for i in rounds:  # relieve, retract, turn, insert again: in that order, every round
        assert [b for b, *_ in steps[i - 1 : i + 3]] == ["rwe", "dither", "ptwl", "ptwl"], steps[
            i - 1 : i + 3
        ]
        assert steps[i][1] == "goal_reached", steps[i]  # on its progress, never its watchdog
        assert steps[i + 1][3].startswith("turn the approach") and steps[i + 1][1] == "goal_reached"
        assert steps[i + 2][2] >= 0.05  # the insertion after a turn starts free, not from a push


def test_one_degree_jams_deep_and_one_new_approach_gets_it_in() -> None:
    """The rigid fit wedges a 1 deg tilt once 5.1 mm of the peg's cylinder is in (2c / theta);
    here it jams 5-6.5 mm in, and the turn that depth implies (0.8-1.0 deg) gets it in."""
    for axis in (0, 1):
        run = run_onboard("sleeve_on_peg", sim=tilted(axis, 1.0))
        assert run.steps[0].report.exit is ExitCondition.WRENCH_BREACH
        jam_travel_mm = float(re.search(r"only ([0-9.]+) mm down", run.steps[1].why).group(1))  # type: ignore[union-attr]
        engaged_mm = jam_travel_mm - 1000 * (MOUTH_M + CHAMFER_M)
        assert 5.0 <= engaged_mm <= 6.5, engaged_mm
        assert run.success and len(run.steps) == 5
        turned_deg = float(re.search(r"turn the approach: ([0-9.]+) deg", run.steps[3].why).group(1))  # type: ignore[union-attr]
        assert turned_deg == pytest.approx(math.degrees(2 * 0.0445 / engaged_mm), abs=0.02)  # 2c / L

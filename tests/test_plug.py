"""Plug insertion (paper 2.3.7, Fig. 10): contact, slide along y in contact until the prongs drop
into the holes and the y force crosses the threshold, insert deep."""

import numpy as np
import pytest

from robot_sim.behaviors import ExitCondition, Pose, Ptwl
from robot_sim.params import PtwlParams, RweParams
from robot_sim.policies import Finish, Step, run_onboard
from robot_sim.scenes import fixture_offset, get_scene
from robot_sim.sim import Simulation
from tests.helpers import DOWN_WXYZ, completed_runs, machine, report_down, state_params

HOME = Pose((0.378, 0.0, 0.2785), DOWN_WXYZ)
# robot_sim/machines/builtin/plug.toml: the slides' attractor this far below the face (~6 N down).
SLIDE_PRESS_M = 0.003


def slide_y_m(decision: object) -> float:
    assert isinstance(decision, Step) and isinstance(decision.params, PtwlParams), decision
    assert decision.params.frame == "base"
    dx, dy, dz = decision.params.translation
    assert dx == 0.0 and dz == pytest.approx(-SLIDE_PRESS_M)  # keeps pressing while it slides
    return dy


# -------------------------------------------------------------------------- the policy
def test_policy_slides_plus_y_then_back_minus_y_then_gives_up() -> None:
    policy = machine("plug")
    assert policy.first(HOME).params == state_params("plug", "approach")
    on_face = report_down(HOME, ExitCondition.WRENCH_BREACH, 0.0150)
    assert slide_y_m(policy.next(on_face)) == pytest.approx(0.012)
    assert slide_y_m(policy.next(report_down(HOME, ExitCondition.TIMEOUT, 0.0150))) == pytest.approx(-0.024)
    gave_up = policy.next(report_down(HOME, ExitCondition.TIMEOUT, 0.0151))
    # No hole either way: the second slide (back along -y) found none.
    assert isinstance(gave_up, Finish) and not gave_up.completed
    assert gave_up.why.startswith("slide_minus ended timeout")


def test_policy_inserts_once_the_prongs_drop_then_relieves_then_completes() -> None:
    policy = machine("plug")
    policy.first(HOME)
    policy.next(report_down(HOME, ExitCondition.WRENCH_BREACH, 0.0150))
    insert = policy.next(report_down(HOME, ExitCondition.WRENCH_BREACH, 0.0172))  # dropped 2.2 mm
    assert isinstance(insert, Step) and insert.params.force_threshold == 15.0 and "prongs in" in insert.why
    assert insert.state == "insert"
    relieve = policy.next(report_down(HOME, ExitCondition.WRENCH_BREACH, 0.0309, peak=15.1))
    assert isinstance(relieve, Step) and isinstance(relieve.params, RweParams) and relieve.state == "relieve"
    done = policy.next(report_down(HOME, ExitCondition.COMPLETED, 0.0308, "rwe"))
    assert isinstance(done, Finish) and done.completed


def test_policy_recovers_a_short_insertion_and_stops_above_the_face() -> None:
    policy = machine("plug")
    policy.first(HOME)
    insert = policy.next(report_down(HOME, ExitCondition.GOAL_REACHED, 0.018))  # straight into the holes
    assert isinstance(insert, Step) and insert.params.translation == [0.0, 0.0, 0.025]
    short = policy.next(report_down(HOME, ExitCondition.WRENCH_BREACH, 0.022, peak=15.2))
    assert isinstance(short, Step) and isinstance(short.params, RweParams) and short.why.startswith("short:")
    assert short.state == "relieve_jam"
    missed = machine("plug")
    missed.first(HOME)
    above = missed.next(report_down(HOME, ExitCondition.GOAL_REACHED, 0.008))
    assert isinstance(above, Finish) and not above.completed


# -------------------------------------------------------------------------- the scene
def test_seeds_put_the_outlet_up_to_10_mm_either_way_in_y_and_half_a_mm_in_x() -> None:
    offsets = np.array(
        [fixture_offset(get_scene("plug"), np.random.default_rng(seed)) for seed in range(200)]
    )
    assert np.abs(offsets[:, 0]).max() <= 0.0005 and np.abs(offsets[:, 1]).max() <= 0.010
    assert (offsets[:, 1] < -0.005).sum() >= 40 and (offsets[:, 1] > 0.005).sum() >= 40


def test_straight_down_the_prongs_stop_on_the_face_and_are_not_in() -> None:
    """The negative case: an offset outlet and no slide keep the prongs on the face."""
    sim = Simulation("plug", seed=0)
    assert abs(sim.model.body("outlet").pos[1]) > 0.003
    report = sim.run_behavior(Ptwl(PtwlParams(translation=[0.0, 0.0, 0.04], force_threshold=15.0)))
    assert report.exit is ExitCondition.WRENCH_BREACH
    assert not sim.task().success and abs(sim.task().progress) < 0.0005  # tips on the face


def test_an_outlet_out_of_the_slides_reach_fails_and_is_not_counted() -> None:
    """A deliberately failed run: the outlet 16 mm off (the slides reach 12) is never found; the
    machine says failed and the predicate agrees."""
    sim = Simulation("plug")
    sim.model.body("outlet").pos[1] += 0.016
    run = run_onboard("plug", sim=sim)
    # No hole either way: the second slide (back along -y) found none.
    assert run.end == "failed" and not run.success and run.why.startswith("slide_minus ended")
    assert [s.params.translation[1] for s in run.steps[1:]] == pytest.approx([0.012, -0.024])


def test_seeded_runs_plug_in_onboard_and_the_y_force_ends_the_slide() -> None:
    runs = completed_runs("plug")
    assert all(r["max_force_n"] <= 20.0 for r in runs), [r["max_force_n"] for r in runs]
    slide_counts = []
    for r in runs:
        offset_y = float(fixture_offset(get_scene("plug"), np.random.default_rng(r["seed"]))[1])
        slides = [s for s in r["steps"] if s["behavior"] == "ptwl" and s["params"]["frame"] == "base"]
        # The outlet's side decides the slides: one along +y, or +y then back along -y.
        assert len(slides) == (1 if offset_y > 0.002 else 2 if offset_y < -0.002 else len(slides))
        slide_counts.append(len(slides))
        if not slides:
            continue  # the prongs fell straight in
        found = slides[-1]
        fx, fy, fz = found["final_wrench"][:3]
        direction = np.sign(found["params"]["translation"][1])
        # Stopped by the slot's far wall: the y force dominates and pushes back against the slide.
        assert -direction * fy > max(abs(fx), abs(fz), 1.0), found["final_wrench"]
        if len(slides) == 2:  # 24 mm back: the wall is met well before the attractor stops
            assert found["exit"] == "wrench_breach" and abs(fy) > 11.0
    assert sorted(slide_counts) == [0, 1, 2]  # TEST_SEEDS reach the three ways in

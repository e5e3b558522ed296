"""The ground twin registers its fixture from the robot's contacts (issue 29 point 6; the
teleoperation paper's 2.5 Model Update). With the plate 1 mm lower than the twin's model, main's
twin restarted with its tool 1 mm inside its own plate, felt a spurious ~50 N and ended the slide
the robot went on with: 22.8 mm off at 1 s RTT, 34 mm at 2 s, worse than no twin (the delayed
picture)."""

import mujoco
import numpy as np
import pytest

from ptwl.experiments.twin.trial import contact_moves, robot_with_model_error, run_trial
from robot_sim.behaviors.ptwl import Ptwl
from robot_sim.behaviors.rwe import Rwe
from robot_sim.params import PtwlParams, RweParams
from robot_sim.sim import Simulation
from web.twin import GroundTwin
from web.twin_registration import MAX_SHIFT_M, FixtureRegistration
from web.twin_trust import twin_readout


def test_a_plate_1_mm_low_is_found_at_the_first_contact_and_the_twin_beats_the_delayed_picture() -> None:
    seen: list[GroundTwin] = []
    nominal = run_trial(
        robot_with_model_error("surface", 3, (0.0, 0.0, -0.001)), 2.0, contact_moves(), 10.0, register=False
    )
    registered = run_trial(
        robot_with_model_error("surface", 3, (0.0, 0.0, -0.001)),
        2.0,
        contact_moves(),
        10.0,
        twin_scene_check=seen.append,
    )
    assert nominal.max_mm > 20.0 and nominal.max_mm > 0.8 * nominal.delayed_max_mm  # main's failure: 34 mm
    after = registered.after_contact_max_mm
    assert after is not None and after < 1.0  # 0.1 mm; the issue asks <= 3
    assert registered.max_mm < 1.5  # before the contact the twin cannot know: the 1 mm itself
    assert registered.max_mm < 0.1 * registered.delayed_max_mm
    [twin] = seen
    assert twin.registered is not None and twin.registered.body == "plate_body"
    dx, dy, dz = twin.registered.shift_m
    assert dz == pytest.approx(-0.001, abs=0.0002) and abs(dx) < 1e-4 and abs(dy) < 1e-4  # sideways: unseen
    assert twin.advanced_wall is not None
    _, readout = twin_readout(twin.advanced_wall, twin)
    assert "its plate_body moved 1.0 mm (+0.0, +0.0, -1.0) to fit the robot's contacts" in readout


def pressed(lift_m: float) -> Simulation:
    """The probe pressed onto the plate at ~10 N; with `lift_m`, relieved (RWE) and lifted that
    far off it."""
    sim = Simulation("surface")
    sim.run_behavior(Ptwl(PtwlParams(translation=[0.0, 0.0, 0.06], duration=2.0, force_threshold=10.0)))
    if lift_m:
        sim.run_behavior(Rwe(RweParams(duration=1.0)))
        sim.run_behavior(
            Ptwl(PtwlParams(translation=[0.0, 0.0, -lift_m], duration=1.0, position_tolerance=1e-4))
        )
    return sim


def tip_to_plate_m(sim: Simulation) -> float:
    model = sim.model
    plate, tip = model.geom("plate").id, model.geom("arm/tool/tool_tip").id
    return float(mujoco.mj_geomDistance(model, sim.data, plate, tip, 0.05, np.zeros(6)))


def test_a_contact_the_twin_lacks_moves_its_fixture_to_it_and_free_on_both_sides_says_nothing() -> None:
    twin = pressed(0.002)  # the twin's tool 2 mm over its plate
    registration = FixtureRegistration(twin)
    registration.observe(twin, force_n=0.5)  # the robot free too: nothing learnt
    assert registration.registered().samples == 0
    registration.observe(twin, force_n=12.0)  # the robot touching where the twin is 2 mm off
    shift = registration.registered().shift_m
    assert shift[2] == pytest.approx(0.002, abs=0.0002) and registration.registered().samples == 1
    assert abs(tip_to_plate_m(twin)) < 1e-4  # now the twin touches, as the robot does


def test_a_twin_inside_its_fixture_while_the_robot_is_free_moves_it_out_and_never_far() -> None:
    twin = pressed(0.0)  # the twin's tool pressed into its plate
    registration = FixtureRegistration(twin)
    inside = registration._closest(twin)
    assert inside is not None and inside[0] < 0.0  # the contact's own overlap
    registration.observe(twin, force_n=0.0)  # the robot free there: the plate is lower
    assert registration.registered().shift_m[2] == pytest.approx(inside[0], abs=1e-5)
    registration._equations.extend([(np.array([0.0, 0.0, 1.0]), 0.05)] * 5)  # 50 mm: not a small error
    registration._solve()
    assert float(np.linalg.norm(registration.registered().shift_m)) == pytest.approx(MAX_SHIFT_M)

"""Wide, shallow lid (paper 2.3.9): the pan off the tool axis by more than the play; the state
machine finds the way to the centre from the torque at first contact."""

import math

import numpy as np
import pytest

from robot_sim.behaviors import BehaviorReport, ExitCondition, Pose, Ptwl
from robot_sim.params import PtwlParams, RweParams
from robot_sim.policies import Finish, Step, lid
from robot_sim.scenes import fixture_offset, get_scene
from robot_sim.sim import Simulation
from tests.helpers import DOWN_WXYZ, completed_runs, report_down

HOME = Pose((0.378, 0.0, 0.2765), DOWN_WXYZ)


def touching(contact_xy_m: tuple[float, float], depth_m: float = 0.0202, fz: float = 8.0) -> BehaviorReport:
    """A breach on the lip: pushed up by fz at contact_xy_m from the port (base axes)."""
    r = report_down(HOME, ExitCondition.WRENCH_BREACH, depth_m, peak=fz)
    rx, ry = contact_xy_m
    wrench = (0.0, 0.0, fz, ry * fz, -rx * fz, 0.0)  # tau = r x f with f = (0, 0, fz)
    return BehaviorReport(r.behavior, r.exit, 0.0, 1.0, fz, 0.8, wrench, r.final_port)


@pytest.mark.parametrize("heading_deg", [0.0, 90.0, 200.0, -45.0])
def test_policy_slides_away_from_the_contact_the_torque_shows(heading_deg: float) -> None:
    policy = lid.Lid()
    policy.first(HOME)
    a = math.radians(heading_deg)
    read = policy.next(touching((0.1 * math.cos(a), 0.1 * math.sin(a))))
    assert isinstance(read, Step) and read.params == lid.READ  # an impact's wrench is not read
    slide = policy.next(touching((0.1 * math.cos(a), 0.1 * math.sin(a))))
    assert isinstance(slide, Step) and isinstance(slide.params, PtwlParams) and slide.params.frame == "base"
    dx, dy, dz = slide.params.translation
    assert math.hypot(dx, dy) == pytest.approx(lid.SLIDE_M)
    assert (dx, dy) == pytest.approx((-lid.SLIDE_M * math.cos(a), -lid.SLIDE_M * math.sin(a)), abs=1e-9)
    assert dz == pytest.approx(-lid.SLIDE_PRESS_M)  # keeps pressing down while it slides
    assert "on the lip" in slide.why and "100 mm off the port" in slide.why


def test_policy_seats_then_relieves_then_completes_and_gives_up_on_the_lip() -> None:
    policy = lid.Lid()
    policy.first(HOME)
    seat = policy.next(report_down(HOME, ExitCondition.WRENCH_BREACH, 0.026))
    assert isinstance(seat, Step) and seat.params == lid.SEAT
    relieve = policy.next(report_down(HOME, ExitCondition.WRENCH_BREACH, 0.0349))
    assert isinstance(relieve, Step) and isinstance(relieve.params, RweParams)
    done = policy.next(report_down(HOME, ExitCondition.COMPLETED, 0.0348, "rwe"))
    assert isinstance(done, Finish) and done.completed
    stuck = lid.Lid()
    stuck.first(HOME)
    for _ in range(stuck.settings.max_recoveries):  # read, slide; read, slide; ...
        read = stuck.next(touching((0.1, 0.0)))
        assert isinstance(read, Step) and read.params == lid.READ
        slide = stuck.next(touching((0.1, 0.0)))
        assert (
            isinstance(slide, Step) and isinstance(slide.params, PtwlParams) and slide.params.frame == "base"
        )
    last_read = stuck.next(touching((0.1, 0.0)))
    assert isinstance(last_read, Step) and last_read.params == lid.READ
    gave_up = stuck.next(touching((0.1, 0.0)))
    assert isinstance(gave_up, Finish) and not gave_up.completed and "after 3 slides" in gave_up.why
    missed = lid.Lid()
    missed.first(HOME)
    nothing = missed.next(report_down(HOME, ExitCondition.GOAL_REACHED, 0.010))  # stopped above the lip
    assert isinstance(nothing, Finish) and not nothing.completed


def test_seeds_put_the_pan_4_to_12_mm_off_in_every_direction() -> None:
    offsets = np.array([fixture_offset(get_scene("lid"), np.random.default_rng(seed)) for seed in range(200)])
    distances = np.linalg.norm(offsets, axis=1)
    assert distances.min() >= 0.004 and distances.max() <= 0.012
    headings = np.degrees(np.arctan2(offsets[:, 1], offsets[:, 0]))
    assert np.histogram(headings, bins=4, range=(-180, 180))[0].min() >= 30  # no favoured quadrant


def test_straight_down_the_lid_lands_on_the_lip_and_is_not_seated() -> None:
    """The negative case: without the slide, an offset pan keeps the lid on its lip."""
    sim = Simulation("lid", seed=1)
    report = sim.run_behavior(Ptwl(lid.APPROACH))
    assert report.exit is ExitCondition.WRENCH_BREACH and not sim.task().success
    assert sim.task().progress < 0.003  # resting on top of the lip


def test_seeded_runs_seat_the_lid_onboard_and_the_machine_agrees() -> None:
    runs = completed_runs("lid")
    assert all(r["max_force_n"] <= 20.0 for r in runs), [r["max_force_n"] for r in runs]

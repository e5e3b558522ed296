"""Berthing (paper 2.3.1, Fig. 3b): a heavy sled on a frictionless plane pressed onto two posts;
the torque at first contact says which way to slide."""

import pytest

from robot_sim.behaviors import BehaviorReport, ExitCondition, Pose, Ptwl
from robot_sim.params import PtwlParams, RweParams
from robot_sim.policies import Finish, Step, run_onboard
from robot_sim.sim import Simulation
from tests.helpers import DOWN_WXYZ, completed_runs, machine, ptwl_state

# robot_sim/machines/builtin/berthing.toml: |tau_z| at first contact under this is aligned.
TAU_THRESH_NM = 0.2


def at(
    x_m: float, exit_condition: ExitCondition, tau_z: float = 0.0, behavior: str = "ptwl"
) -> BehaviorReport:
    """A report with the port at base x = x_m and torque tau_z about the base z."""
    wrench = (-14.0, 0.0, 0.0, 0.0, 0.0, tau_z)
    return BehaviorReport(
        behavior, exit_condition, 0.0, 1.0, 15.0, abs(tau_z), wrench, Pose((x_m, 0.0, 0.28), DOWN_WXYZ)
    )


# -------------------------------------------------------------------------- the policy
@pytest.mark.parametrize(("tau_z", "toward_y"), [(0.6, 1.0), (-0.6, -1.0)])
def test_policy_slides_toward_the_side_the_torque_at_first_contact_gives(
    tau_z: float, toward_y: float
) -> None:
    policy = machine("berthing")
    approach = policy.first(Pose((0.378, 0.0, 0.28), DOWN_WXYZ))
    assert approach.params == ptwl_state("berthing", "approach") and approach.params.preset == "planar"
    slide = policy.next(at(0.40, ExitCondition.WRENCH_BREACH, tau_z))
    assert isinstance(slide, Step) and isinstance(slide.params, PtwlParams)
    assert slide.state == ("slide_left" if toward_y > 0 else "slide_right")
    dx, dy, _ = slide.params.translation
    assert dy == pytest.approx(toward_y * 0.012) and dx > 0.0  # sideways, keeping forward pressure


def test_policy_presses_until_a_press_no_longer_advances_then_completes() -> None:
    policy = machine("berthing")
    policy.first(Pose((0.378, 0.0, 0.28), DOWN_WXYZ))
    press = policy.next(at(0.40, ExitCondition.WRENCH_BREACH, 0.05))  # aligned: press at once
    assert isinstance(press, Step) and press.params == ptwl_state("berthing", "press")
    relieve = policy.next(at(0.404, ExitCondition.WRENCH_BREACH))  # advanced 4 mm: again
    assert isinstance(relieve, Step) and isinstance(relieve.params, RweParams) and relieve.state == "relieve"
    again = policy.next(at(0.404, ExitCondition.COMPLETED, behavior="rwe"))
    assert isinstance(again, Step) and again.params == ptwl_state("berthing", "press")
    last = policy.next(at(0.4045, ExitCondition.WRENCH_BREACH))  # 0.5 mm: seated
    assert isinstance(last, Step) and isinstance(last.params, RweParams) and last.state == "done"
    done = policy.next(at(0.4045, ExitCondition.COMPLETED, behavior="rwe"))
    assert isinstance(done, Finish) and done.completed and done.why.startswith("done ended completed")
    assert policy.visits["press"] == 2  # seated after 2 presses


def test_policy_fails_without_contact_and_after_too_many_presses() -> None:
    lost = machine("berthing")
    lost.first(Pose((0.378, 0.0, 0.28), DOWN_WXYZ))
    nothing = lost.next(at(0.438, ExitCondition.GOAL_REACHED))
    # No contact: the approach ended without a breach.
    assert isinstance(nothing, Finish) and not nothing.completed
    assert nothing.why.startswith("approach ended goal_reached")
    creeping = machine("berthing", {"max_recoveries": 1})
    creeping.first(Pose((0.378, 0.0, 0.28), DOWN_WXYZ))
    x = 0.40
    creeping.next(at(x, ExitCondition.WRENCH_BREACH, 0.05))
    for _ in range(2):
        x += 0.003
        assert isinstance(creeping.next(at(x, ExitCondition.WRENCH_BREACH)), Step)  # relieve
        decision = creeping.next(at(x, ExitCondition.COMPLETED, behavior="rwe"))
    # Still advancing after 2 presses: the third is more than max_recoveries + 1 allows.
    assert isinstance(decision, Finish) and not decision.completed
    assert decision.why.startswith("relieve ended completed") and creeping.visits["press"] == 2


# -------------------------------------------------------------------------- the scene
@pytest.mark.parametrize("seed", [0, 2])  # posts off to +y, to -y
def test_the_torque_at_first_contact_points_to_the_posts_side_and_a_press_alone_does_not_seat(
    seed: int,
) -> None:
    """The paper's cue and the negative case: pressed straight on, the torque's sign is the side
    the posts are off to, and the clamps are not seated."""
    sim = Simulation("berthing", seed=seed)
    posts_y = float(sim.model.body("posts").pos[1])
    report = sim.run_behavior(Ptwl(ptwl_state("berthing", "approach")))
    assert report.exit is ExitCondition.WRENCH_BREACH
    assert abs(report.final_wrench[5]) > TAU_THRESH_NM and report.final_wrench[5] * posts_y > 0.0
    assert not sim.task().success and sim.task().progress > 0.002


def test_a_stop_on_the_flat_face_is_not_counted_whatever_the_machine_says() -> None:
    """A deliberately failed run: the posts 25 mm sideways, outside the clamps; the sled stops
    on its flat face. The machine cannot tell that from a seat (a press no longer advances), but
    the predicate, which judges the run, can."""
    sim = Simulation("berthing")
    sim.model.body("posts").pos[1] += 0.025
    run = run_onboard("berthing", sim=sim)
    assert not run.success and run.progress > 0.02


def test_posts_out_of_reach_fail_the_machine() -> None:
    sim = Simulation("berthing")
    sim.model.body("posts").pos[0] += 0.1
    run = run_onboard("berthing", sim=sim)
    # No contact: the approach ended without a breach.
    assert run.end == "failed" and not run.success and run.why.startswith("approach ended")
    assert "wrench_breach" not in run.why


def test_seeded_runs_berth_the_sled_onboard_sliding_either_way() -> None:
    runs = completed_runs("berthing")
    assert all(r["max_force_n"] <= 20.0 for r in runs), [r["max_force_n"] for r in runs]
    slides = sorted(r["steps"][1]["state"] for r in runs)
    assert slides == ["slide_left", "slide_left", "slide_right"], slides  # TEST_SEEDS: both ways

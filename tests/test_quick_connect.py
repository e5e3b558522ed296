"""Quick-disconnect coupling (paper 2.3.6): a snap fit needing 25-30 N, and its state machine."""

import pytest

from robot_sim.behaviors import BehaviorReport, ExitCondition, Pose, Ptwl, Rwe
from robot_sim.geometry import body_poses, moving_bodies
from robot_sim.params import DitherParams, PtwlParams, RweParams
from robot_sim.policies import Finish, Step, run_onboard
from robot_sim.scenes import LATCH_STROKE_M
from robot_sim.sim import Simulation
from tests.helpers import DOWN_WXYZ, completed_runs, machine, ptwl_state, report_down, state_params

HOME = Pose((0.378, 0.0, 0.2765), DOWN_WXYZ)
# robot_sim/machines/builtin/quick_connect.toml: travel from home past which the nipple has
# pushed the collar through (the insert's guard).
SEATED_M = 0.039


def at(
    depth_m: float, exit_condition: ExitCondition, behavior: str = "ptwl", peak: float = 30.0
) -> BehaviorReport:
    return report_down(HOME, exit_condition, depth_m, behavior, peak)


def collar_m(sim: Simulation) -> float:
    return float(sim.data.qpos[sim.model.jnt_qposadr[sim.model.joint("collar_slide").id]])


# -------------------------------------------------------------------------- the policy
def test_policy_relieves_once_seated_then_completes() -> None:
    policy = machine("quick_connect")
    assert policy.first(HOME).params.force_threshold == 35.0  # above the latch's 25-30 N
    relieve = policy.next(at(0.0405, ExitCondition.WRENCH_BREACH, peak=35.2))
    # Seated 40.5 mm down: the insert's guard read the travel.
    assert (
        isinstance(relieve, Step)
        and isinstance(relieve.params, RweParams)
        and relieve.state == "relieve"
        and "travel(tool z) 0.0405" in relieve.why
    )
    done = policy.next(at(0.0402, ExitCondition.COMPLETED, "rwe"))
    assert isinstance(done, Finish) and done.completed and done.why.startswith("relieve ended completed")


def test_policy_recovers_a_short_insertion_and_gives_up_after_three() -> None:
    policy = machine("quick_connect")
    policy.first(HOME)
    for short in range(1, int(policy.settings.max_recoveries) + 1):
        relieve = policy.next(at(0.022, ExitCondition.WRENCH_BREACH, peak=36.0))
        assert (
            isinstance(relieve, Step)
            and isinstance(relieve.params, RweParams)
            and relieve.why.startswith("short:")
            and relieve.state == "relieve_jam"
            and policy.visits["relieve_jam"] == short
        )
        twist = policy.next(at(0.022, ExitCondition.COMPLETED, "rwe"))
        assert isinstance(twist, Step) and isinstance(twist.params, DitherParams)
        assert twist.params.progress == 0.005  # it ends once the plug has gone 5 mm further in
        # The twist's push is relieved before the insertion goes again from it.
        again = policy.next(at(0.025, ExitCondition.TIMEOUT, "dither"))
        assert isinstance(again, Step) and isinstance(again.params, RweParams)
        insert = policy.next(at(0.025, ExitCondition.COMPLETED, "rwe"))
        assert isinstance(insert, Step) and insert.params == state_params("quick_connect", "insert")
    gave_up = policy.next(at(0.022, ExitCondition.WRENCH_BREACH))
    # Still short after 3 recoveries.
    assert isinstance(gave_up, Finish) and not gave_up.completed and gave_up.why.startswith("insert ended")
    assert policy.visits["relieve_jam"] == 3


def test_policy_treats_a_stop_at_the_collar_as_short_whatever_the_exit() -> None:
    policy = machine("quick_connect")
    policy.first(HOME)
    decision = policy.next(at(SEATED_M - 0.001, ExitCondition.TIMEOUT))
    assert (
        isinstance(decision, Step) and decision.why.startswith("short:") and decision.state == "relieve_jam"
    )
    assert policy.visits["relieve_jam"] == 1  # the first recovery


# -------------------------------------------------------------------------- the physics
def test_the_latch_needs_25_to_30_n_and_the_default_threshold_stops_at_the_collar() -> None:
    sim = Simulation("quick_connect")
    report = sim.run_behavior(Ptwl(PtwlParams(translation=[0.0, 0.0, 0.06], duration=6.0)))  # 20 N
    assert report.exit is ExitCondition.WRENCH_BREACH and not sim.task().success
    assert collar_m(sim) < LATCH_STROKE_M  # pushed on the collar, did not get it through
    # Pushed through at up to 35 N: it latches, and the latch holds once the press is relieved.
    sim = Simulation("quick_connect")
    collar = sim.model.body("collar").id
    assert collar in moving_bodies(sim.model)  # telemetry carries it: a console draws it moving
    z_before = body_poses(sim.model, sim.data, [collar])["collar"][2]
    pushed = sim.run_behavior(Ptwl(ptwl_state("quick_connect", "insert")))
    assert sim.task().success and 25.0 <= pushed.peak_force <= 36.0
    relieve = state_params("quick_connect", "relieve")
    assert isinstance(relieve, RweParams)
    assert sim.run_behavior(Rwe(relieve)).exit is ExitCondition.COMPLETED
    for _ in range(2000):
        sim.step()
    assert sim.task().success and collar_m(sim) == pytest.approx(LATCH_STROKE_M, abs=3e-4)
    z_after = body_poses(sim.model, sim.data, [collar])["collar"][2]
    assert z_before - z_after == pytest.approx(LATCH_STROKE_M, abs=3e-4)


def test_seeded_runs_latch_onboard_and_the_machine_agrees() -> None:
    runs = completed_runs("quick_connect")
    peaks = [r["max_force_n"] for r in runs]
    assert all(25.0 <= peak <= 40.0 for peak in peaks), peaks  # the latch's force, under the limit


def test_a_machine_that_pushes_too_softly_fails_and_is_not_a_success() -> None:
    """The predicate's negative case: 20 N never gets the latch through."""
    run = run_onboard("quick_connect", 0, overrides={"insert_force_threshold": 20.0, "max_recoveries": 0})
    assert run.end == "failed" and not run.success and run.progress < LATCH_STROKE_M

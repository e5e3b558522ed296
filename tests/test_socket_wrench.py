"""Socket wrench insertion (paper 2.3.10, Fig. 13): the detent ball catches the socket's edge on
every insertion; tilting toward it presses it in."""

import pytest

from robot_sim.behaviors import ExitCondition, Pose, Ptwl
from robot_sim.params import PtwlParams, RweParams
from robot_sim.policies import Finish, Step, run_onboard
from robot_sim.sim import Simulation
from tests.helpers import DOWN_WXYZ, completed_runs, machine, ptwl_state, report_down

HOME = Pose((0.378, 0.0, 0.2965), DOWN_WXYZ)


def ball_out_m(sim: Simulation) -> float:
    """[m] the detent ball's travel on its spring: 0 all the way out, -0.0009 pushed flush."""
    return float(sim.data.qpos[sim.model.joint("arm/tool/detent_slide").qposadr[0]])


# -------------------------------------------------------------------------- the policy
def test_policy_tilts_toward_the_detent_when_caught_then_inserts_upright_then_relieves() -> None:
    policy = machine("socket_wrench")
    assert policy.first(HOME).params == ptwl_state("socket_wrench", "approach")
    tilt = policy.next(report_down(HOME, ExitCondition.WRENCH_BREACH, 0.0147, peak=15.2))
    # Caught at the mouth (the detent ball on the edge): tilt.
    assert isinstance(tilt, Step) and isinstance(tilt.params, PtwlParams) and tilt.state == "tilt"
    assert tilt.params.rotation == [0.0, -0.07, 0.0]  # the top toward tool +x, the ball's side
    insert = policy.next(report_down(HOME, ExitCondition.TIMEOUT, 0.0170))
    assert isinstance(insert, Step) and isinstance(insert.params, PtwlParams)
    assert insert.params.rotation == [0.0, 0.07, 0.0] and insert.params.translation[2] == 0.02
    relieve = policy.next(report_down(HOME, ExitCondition.TIMEOUT, 0.0300))
    assert isinstance(relieve, Step) and isinstance(relieve.params, RweParams) and relieve.state == "relieve"
    done = policy.next(report_down(HOME, ExitCondition.COMPLETED, 0.0300, "rwe"))
    assert isinstance(done, Finish) and done.completed


def test_policy_tilts_again_after_a_short_insert_and_gives_up_after_max_recoveries() -> None:
    policy = machine("socket_wrench", {"max_recoveries": 2, "tilt_rad": 0.05})
    policy.first(HOME)
    first = policy.next(report_down(HOME, ExitCondition.WRENCH_BREACH, 0.015))
    assert isinstance(first, Step) and first.params.rotation == [0.0, -0.05, 0.0]  # type: ignore[union-attr]
    policy.next(report_down(HOME, ExitCondition.TIMEOUT, 0.016))  # the insert
    for _ in range(2):
        relieve = policy.next(report_down(HOME, ExitCondition.WRENCH_BREACH, 0.016))
        assert isinstance(relieve, Step) and isinstance(relieve.params, RweParams) and "short" in relieve.why
        assert relieve.state == "relieve_jam"
        tilt = policy.next(report_down(HOME, ExitCondition.COMPLETED, 0.016, "rwe"))
        assert isinstance(tilt, Step) and tilt.params == ptwl_state("socket_wrench", "tilt", tilt_rad=0.05)
        insert = policy.next(report_down(HOME, ExitCondition.TIMEOUT, 0.016))
        assert isinstance(insert, Step) and insert.params == ptwl_state(
            "socket_wrench", "insert", tilt_rad=0.05
        )
    gave_up = policy.next(report_down(HOME, ExitCondition.WRENCH_BREACH, 0.016))
    # Still short after 3 tilts.
    assert isinstance(gave_up, Finish) and not gave_up.completed and gave_up.why.startswith("insert ended")
    assert policy.visits["tilt"] == 3
    above = machine("socket_wrench")
    above.first(HOME)
    missed = above.next(report_down(HOME, ExitCondition.GOAL_REACHED, 0.006))
    assert isinstance(missed, Finish) and not missed.completed


# -------------------------------------------------------------------------- the scene
def test_a_straight_push_stops_with_the_ball_on_the_edge_and_is_not_in() -> None:
    """The negative case and the paper's jam: at 15 N the shank stops ~5 mm in, where the ball
    meets the socket's edge, the ball still out."""
    sim = Simulation("socket_wrench", seed=0)
    report = sim.run_behavior(Ptwl(ptwl_state("socket_wrench", "approach")))
    assert report.exit is ExitCondition.WRENCH_BREACH
    assert 0.004 < sim.task().progress < 0.0065 and not sim.task().success  # the ball is 6 mm up
    assert ball_out_m(sim) > -0.0002


@pytest.mark.parametrize("seed", [0, 4])
def test_tilting_toward_the_detent_presses_the_ball_in(seed: int) -> None:
    """The same 4 mm press after the catch, upright, tilted toward the ball and tilted away: only
    toward presses the ball half a millimetre in."""
    pressed = {}
    for name, tilt in (("upright", 0.0), ("toward", -0.07), ("away", 0.07)):
        sim = Simulation("socket_wrench", seed=seed)
        sim.run_behavior(Ptwl(ptwl_state("socket_wrench", "approach")))
        sim.run_behavior(
            Ptwl(
                PtwlParams(
                    translation=[0, 0, 0.004],
                    rotation=[0, tilt, 0],
                    duration=2.0,
                    watchdog=2.5,
                    force_threshold=40.0,  # no breach: the press and the tilt alone decide
                    preset="medium",
                )
            )
        )
        pressed[name] = ball_out_m(sim)
    assert pressed["toward"] < -0.00045, pressed
    assert pressed["upright"] > -0.00035 and pressed["away"] > -0.0004, pressed


def test_a_socket_off_beyond_the_chamfer_fails_and_is_not_counted() -> None:
    """A deliberately failed run: the socket 3 mm off, the tip lands on its top; the machine
    tilts and pushes, then says failed, and the predicate agrees."""
    sim = Simulation("socket_wrench")
    sim.model.body("socket").pos[0] += 0.003
    run = run_onboard("socket_wrench", sim=sim, overrides={"max_recoveries": 1})
    # Still short after 2 tilts: relieve_jam's visits used up (not the guard above the socket).
    assert run.end == "failed" and not run.success and run.why.startswith("insert ended")
    assert run.why.endswith("relieve_jam used its 1 visits: failed")
    assert sum(s.state == "tilt" for s in run.steps) == 2


def test_seeded_runs_insert_the_shank_onboard_each_after_tilting_past_the_ball() -> None:
    runs = completed_runs("socket_wrench")
    assert all(r["max_force_n"] <= 30.0 for r in runs), [r["max_force_n"] for r in runs]
    for r in runs:  # even aligned, the ball catches every time, and the tilt follows
        assert r["steps"][1]["state"] == "tilt", r["steps"][1]["why"]  # caught at the mouth

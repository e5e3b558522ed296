"""The force task monitor (issue 14; the teleoperation paper's 2.4.1 and 2.5.2): RLS with a
forgetting factor per parameter, and slides on the friction_step plate: the friction learned,
a step in friction and a jam flagged `anomaly`, a plain slide left alone."""

import math

import numpy as np
import pytest

from robot_sim.behaviors import ExitCondition, behavior_for
from robot_sim.params import MonitorSpec, PtwlParams
from robot_sim.rls import VectorForgettingRls
from robot_sim.scenes.friction_step import MU_SMOOTH, SEAM_Y_M
from robot_sim.sim import Simulation
from robot_sim.task_monitor import FrictionMonitor, Sample
from robot_sim.telemetry import state_fields
from server.models import MonitorModel


def test_rls_learns_a_line_and_its_fast_parameter_follows_a_step() -> None:
    rng = np.random.default_rng(0)
    rls = VectorForgettingRls(np.zeros(2), 100.0, np.array([0.999, 0.95]), 100.0)
    for _ in range(400):  # F_t = 0.4 F_n + 2 N, F_n 2 to 20 N, 0.05 N noise
        normal = rng.uniform(2.0, 20.0)
        rls.update(np.array([normal, 1.0]), 0.4 * normal + 2.0 + rng.normal(0.0, 0.05))
    assert rls.theta == pytest.approx([0.4, 2.0], rel=0.01)
    assert rls.updates == 400  # what the monitor says as "samples learned"
    for i in range(60):  # the constant steps to 5 N: the fast-forgetting parameter takes it
        normal = rng.uniform(2.0, 20.0)
        rls.update(np.array([normal, 1.0]), 0.4 * normal + 5.0)
        if i == 59:  # mu, slow to forget, moved a little meanwhile
            assert rls.theta[1] == pytest.approx(5.0, rel=0.02) and rls.theta[0] == pytest.approx(
                0.4, rel=0.05
            )


def test_rls_covariance_stays_bounded_without_excitation() -> None:
    rls = VectorForgettingRls(np.zeros(2), 1.0, np.array([0.99, 0.99]), 50.0)
    for _ in range(5000):  # the same regressor for ever: forgetting alone would inflate P
        rls.update(np.array([10.0, 1.0]), 3.0)
    assert np.all(np.diag(rls.P) <= 50.0 + 1e-9) and np.all(np.linalg.eigvalsh(rls.P) >= -1e-9)
    assert rls.predict(np.array([10.0, 1.0])) == pytest.approx(3.0, abs=1e-6)
    # Forgetting did inflate the direction the data never excite, up to the cap and no further;
    # along the regressor the data keep it small.
    assert max(np.diag(rls.P)) == pytest.approx(50.0, rel=1e-9)
    phi = np.array([10.0, 1.0])
    assert float(phi @ rls.P @ phi) == pytest.approx(0.02, rel=0.05)


def test_rls_with_equal_factors_is_the_textbook_update() -> None:
    """theta += K (y - phi theta), K = P phi / (1 + phi P phi), P = (P - K phi^T P) / lambda."""
    P0, lam = np.array([[2.0, 0.3], [0.3, 1.0]]), 0.9
    rls = VectorForgettingRls(np.array([0.5, -1.0]), 1.0, np.array([lam, lam]), 1e9)
    rls.P = P0.copy()
    phi, y = np.array([3.0, 1.0]), 2.0
    K = P0 @ phi / (1.0 + phi @ P0 @ phi)
    rls.update(phi, y)
    np.testing.assert_allclose(rls.theta, np.array([0.5, -1.0]) + K * (y - phi @ np.array([0.5, -1.0])))
    np.testing.assert_allclose(rls.P, (P0 - np.outer(K, phi @ P0)) / lam)


def pressed(depth_m: float) -> Simulation:
    """friction_step with the probe tip pressed `depth_m` into the plate (medium stiffness:
    2000 N/m, so ~2 N per mm)."""
    sim = Simulation("friction_step")
    tip_on_plate_z = 0.220 + 0.008  # the plate's top face + the ball's radius
    down = tip_on_plate_z - depth_m - float(sim.controller.p_world_port[2])
    press = PtwlParams(translation=[0, 0, down], frame="base", duration=1.0, watchdog=2.0, preset="medium")
    sim.run_behavior(behavior_for(press))
    return sim


def slide(
    sim: Simulation, dy_m: float, dz_m: float, monitor: bool = True
) -> tuple[list[tuple[float, float, float]], object]:
    """A 3 s PTWL slide along y (pressing dz deeper); per tick (t, port y, monitor mu) and the report."""
    params = PtwlParams(
        translation=[0, dy_m, dz_m],
        frame="base",
        duration=3.0,
        force_threshold=60.0,
        monitor={} if monitor else None,
    )
    sim.start(behavior_for(params))
    trace = []
    while True:
        report = sim.step()
        mu = sim.monitor.mu if sim.monitor is not None else float("nan")
        trace.append((sim.time, float(sim.controller.p_world_port[1]), mu))
        if report is not None:
            return trace, report


def test_a_step_in_friction_is_learned_then_flagged_within_0_2_s() -> None:
    """Slide from the smooth part (mu 0.3) onto the rough one (0.6), the normal force ramping
    4 -> ~20 N so mu and c are both seen: mu is learned within 5 % before the seam and the step
    ends the slide `anomaly` within 0.2 s of the tip crossing it."""
    sim = pressed(0.002)
    trace, report = slide(sim, 0.045, -0.010)
    assert report.exit == ExitCondition.ANOMALY, report
    crossed = next(t for t, y, _ in trace if y >= SEAM_Y_M) if trace[-1][1] >= SEAM_Y_M else trace[-1][0]
    assert abs(report.ended_at - crossed) <= 0.2
    mu_before = [mu for t, y, mu in trace if y < SEAM_Y_M - 0.002]
    assert mu_before[-1] == pytest.approx(MU_SMOOTH, rel=0.05)
    assert "force task monitor" in report.detail and "predicted" in report.detail
    assert sim.monitor is not None and sim.monitor.anomaly and sim.monitor.fields()["anomaly"] is True


def test_a_jam_on_the_ridge_is_flagged_before_the_wrench_limit() -> None:
    sim = pressed(0.003)
    trace, report = slide(sim, -0.09, -0.002)
    assert report.exit == ExitCondition.ANOMALY, report
    assert report.peak_force < 40.0  # long before the 60 N breach a jam without the monitor ends in
    assert trace[-1][1] < -0.045  # at the ridge (centre -60 mm, 3 mm half-width, 8 mm ball)


def test_the_jam_without_the_monitor_runs_into_the_wrench_limit() -> None:
    """The monitor is opt-in: the same slide without it pushes on until the breach."""
    sim = pressed(0.003)
    _, report = slide(sim, -0.09, -0.002, monitor=False)
    assert report.exit == ExitCondition.WRENCH_BREACH and sim.monitor is None


def test_a_plain_slide_and_its_stop_are_not_anomalies() -> None:
    sim = pressed(0.003)
    trace, report = slide(sim, -0.04, -0.002)  # stops short of the ridge, stays pressed
    assert report.exit != ExitCondition.ANOMALY, report.detail
    assert sim.monitor is not None and sim.monitor.fields()["samples_learned"] > 100
    assert trace[-1][2] == pytest.approx(MU_SMOOTH, rel=0.05)


def judge(monitor: FrictionMonitor, normal_n: float, tangential_n: float, speed_m_s: float, n: int) -> bool:
    return any([monitor._judge(Sample(normal_n, tangential_n, speed_m_s)) for _ in range(n)])


def test_too_little_force_is_an_anomaly_only_while_sliding() -> None:
    """Sliding, a force well under mu |F_n| is off the model (the paper's "higher or lower": e.g.
    the tool lost its bite); stuck, static friction may hold anything below it, so only a force
    above the band is."""
    monitor = FrictionMonitor(MonitorSpec(), control_dt_s=0.001)
    for normal_n in np.linspace(4.0, 16.0, 60):  # learn mu 0.3 while sliding at 10 mm/s
        assert not judge(monitor, normal_n, 0.3 * normal_n, 0.01, 1)
    assert monitor.judging and monitor.mu == pytest.approx(0.3, rel=0.05)
    assert not judge(monitor, 10.0, 0.2, 0.0, 10)  # stuck, hardly any tangential force: fine
    assert not judge(monitor, 10.0, 3.0, 0.01, 10)  # sliding on the model
    assert judge(monitor, 10.0, 0.2, 0.01, 3)  # sliding with almost no friction: 3 samples, 30 ms
    assert judge(FrictionMonitor(MonitorSpec(), 0.001), 10.0, 9.0, 0.0, 100) is False  # not learned yet


def test_telemetry_carries_the_monitors_estimates_and_residual() -> None:
    sim = pressed(0.003)
    _, report = slide(sim, -0.09, -0.002)
    state = state_fields(sim, [])
    monitor = MonitorModel(**state["monitor"])  # the API's schema for it
    assert monitor.anomaly and report.exit == ExitCondition.ANOMALY
    assert monitor.mu == pytest.approx(MU_SMOOTH, rel=0.05)
    assert monitor.residual is not None and monitor.residual > monitor.band > 0.0
    assert state_fields(Simulation("friction_step"), [])["monitor"] is None  # none asked for


def test_mu_is_learned_within_5_percent_at_a_constant_4_n_press() -> None:
    """At one normal force mu |F_n| + c cannot tell mu from c; with equal priors the monitor gave
    part of the friction to c (mu read 0.25-0.28 for 0.3) and noise drifted it further."""
    monitor = FrictionMonitor(MonitorSpec(), control_dt_s=0.001)
    rng = np.random.default_rng(1)
    for _ in range(300):  # 3 s of 10 ms samples, sliding at 5 mm/s
        monitor._judge(Sample(4.0, 0.3 * 4.0 + rng.normal(0.0, 0.05), 0.005))
    assert monitor.mu == pytest.approx(0.3, rel=0.05) and abs(monitor.c_n) < 0.1


def test_a_constant_force_is_still_learned_once_the_normal_force_varies() -> None:
    """The paper's cutting force: F_t = mu |F_n| + c with c = 2 N, pressed from 4 to 20 N."""
    monitor = FrictionMonitor(MonitorSpec(), control_dt_s=0.001)
    for normal_n in np.linspace(4.0, 20.0, 300):
        monitor._judge(Sample(normal_n, 0.3 * normal_n + 2.0, 0.005))
    assert monitor.mu == pytest.approx(0.3, rel=0.05) and monitor.c_n == pytest.approx(2.0, rel=0.10)
    assert monitor.judging_floor_n() == 1.0  # c alone exceeds the band's floor: judged once in contact


def test_below_the_force_where_it_can_judge_it_says_so_instead_of_passing() -> None:
    """Issue 29: under 2 N a rough patch (friction doubled) stayed inside the band's 1 N floor and
    nothing said the monitor was blind there."""
    monitor = FrictionMonitor(MonitorSpec(), control_dt_s=0.001)
    for normal_n in np.linspace(4.0, 16.0, 60):  # mu 0.3 learned
        judge(monitor, normal_n, 0.3 * normal_n, 0.01, 1)
    assert monitor.judging and monitor.not_judging is None
    floor_n = monitor.judging_floor_n()
    assert floor_n == pytest.approx(1.0 / 0.3, rel=0.05)  # band_min / mu: where mu |F_n| = 1 N
    assert not judge(monitor, 1.8, 0.6 * 1.8, 0.01, 10)  # the rough patch at 1.8 N: not seen...
    assert (
        not monitor.judging and monitor.not_judging == f"normal force 1.80 N < {floor_n:.2f} N"
    )  # ...and said
    assert monitor.fields()["not_judging"] == monitor.not_judging
    assert not judge(monitor, 0.5, 0.0, 0.01, 1)  # lifted off: out of contact, said against 1 N
    assert monitor.not_judging == "normal force 0.50 N < 1.00 N"
    assert judge(monitor, 6.0, 0.6 * 6.0, 0.01, 3)  # the same patch pressed at 6 N: flagged
    assert monitor.judging and monitor.not_judging is None


def test_below_the_judging_floor_a_jam_is_still_an_anomaly() -> None:
    monitor = FrictionMonitor(MonitorSpec(), control_dt_s=0.001)
    for normal_n in np.linspace(4.0, 16.0, 60):
        judge(monitor, normal_n, 0.3 * normal_n, 0.01, 1)
    assert judge(monitor, 2.0, 5.0, 0.0, 3)  # 5 N tangential at 2 N normal: residual 4.4 N > 1 N
    assert monitor.not_judging is not None and monitor.anomaly
    # Learned nearly frictionless: no press makes a doubling show, so it never judges friction.
    slippery = FrictionMonitor(MonitorSpec(), control_dt_s=0.001)
    for normal_n in np.linspace(4.0, 16.0, 60):
        judge(slippery, normal_n, 0.0, 0.01, 1)
    assert slippery.judging_floor_n() == math.inf
    assert not judge(slippery, 10.0, 0.5, 0.01, 5) and slippery.not_judging == "normal force 10.00 N < inf N"
    assert judge(slippery, 10.0, 6.0, 0.01, 3)  # a 6 N jam at 10 N: still caught


def test_leaving_contact_restarts_the_count_toward_persist_and_the_detail_says_the_forces() -> None:
    """Off the band for 20 ms, lifted off, then off again: an anomaly only after another full
    30 ms (`persist`), and its detail names the sample's forces."""
    monitor = FrictionMonitor(MonitorSpec(), control_dt_s=0.001)
    assert monitor.ticks_per_window == 10  # one sample per 10 ms at 1 kHz
    for normal_n in np.linspace(4.0, 16.0, 60):  # mu 0.3 learned
        judge(monitor, normal_n, 0.3 * normal_n, 0.01, 1)
    assert not judge(monitor, 10.0, 6.0, 0.01, 2)  # 6 N against 3 +- 1 N: off, 20 ms
    assert monitor.outside_s == pytest.approx(0.02)
    assert not judge(monitor, 0.5, 0.0, 0.01, 1) and monitor.outside_s == 0.0  # lifted off
    assert not judge(monitor, 10.0, 6.0, 0.01, 2)
    monitor.last = Sample(10.0, 6.0, 0.01)  # update() keeps each window's sample; _judge alone does not
    assert monitor._judge(monitor.last)  # the third window in a row since contact again
    assert monitor.detail().startswith("force task monitor: tangential force 6.00 N at normal 10.00 N, ")
    assert monitor.detail().endswith(" for 30 ms")


def test_a_constant_force_at_the_bands_floor_judges_from_contact_on() -> None:
    """Learned mu 0 and c exactly the band's floor (1 N): the constant force alone fills the
    floor, so it judges from the contact force up, not never."""
    monitor = FrictionMonitor(MonitorSpec(), control_dt_s=0.001)
    monitor.rls.theta[:] = [0.0, 1.0]
    assert monitor.judging_floor_n() == 1.0
    monitor.rls.theta[:] = [0.0, 0.99]
    assert monitor.judging_floor_n() == math.inf

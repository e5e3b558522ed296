"""The compiled loop (robot_sim/tick.py) run many ticks a call does what one call a tick does,
to the bit; it stops where Python must decide; and the warm-up loads every entry point."""

import math
import os
import subprocess
import sys

import numpy as np
import pytest

from robot_sim import tick
from robot_sim.behaviors import BehaviorParams, BehaviorReport, ExitCondition, behavior_for
from robot_sim.params import DitherParams, GripperParams, MonitorSpec, PtwlParams, RweParams
from robot_sim.sim import UNBOUNDED_TICKS, Simulation

# On the plate (the probe's z points down, into it): a press that breaches (`on_breach: limit`
# moves the attractor mid-tick), an RWE that relieves (its end reads the wrench), a dither
# sliding with the task monitor (a window judged every 10 ticks) to its travel, a press held
# to its timeout.
SEQUENCE: list[BehaviorParams] = [
    PtwlParams(translation=[0.0, 0.0, 0.06], duration=1.0, force_threshold=10.0),
    RweParams(duration=0.3),
    DitherParams(
        mode="translational",
        amplitude=0.002,
        frequency=2.0,
        axis=[1.0, 0.0, 0.0],
        travel=0.02,
        duration=1.0,
        force_threshold=12.0,
        monitor=MonitorSpec(normal=[0.0, 0.0, 1.0]),
    ),
    PtwlParams(translation=[0.0, 0.0, 0.004], duration=0.2, force_threshold=100.0, watchdog=0.4),
]


def run_one_tick_a_call(sim: Simulation, params: BehaviorParams) -> tuple[BehaviorReport, int]:
    sim.start(behavior_for(params))
    ticks = 0
    while True:
        report = sim.step()
        ticks += 1
        if report is not None:
            return report, ticks


def run_many_ticks_a_call(sim: Simulation, params: BehaviorParams) -> tuple[BehaviorReport, int]:
    sim.start(behavior_for(params))
    report, ticks = sim.advance(UNBOUNDED_TICKS)
    assert report is not None
    return report, ticks


def test_many_ticks_a_call_end_each_behavior_on_the_same_tick_with_the_same_state_to_the_bit() -> None:
    one, many = Simulation("surface"), Simulation("surface")
    exits = []
    for params in SEQUENCE:
        report_one, ticks_one = run_one_tick_a_call(one, params)
        report_many, ticks_many = run_many_ticks_a_call(many, params)
        assert report_many == report_one  # exit, times, peaks, final wrench and port, detail
        assert ticks_many == ticks_one
        np.testing.assert_array_equal(many.data.qpos, one.data.qpos)
        np.testing.assert_array_equal(many.data.qvel, one.data.qvel)
        np.testing.assert_array_equal(many.controller.f, one.controller.f)  # the whole state
        if isinstance(params, DitherParams):  # its windows were judged, alike
            assert one.monitor is not None and many.monitor is not None and one.monitor.last is not None
            assert many.monitor.fields() == one.monitor.fields()
        exits.append(report_one.exit)
    # The sequence reaches every way back to Python it was written for.
    assert exits == [
        ExitCondition.WRENCH_BREACH,
        ExitCondition.COMPLETED,
        ExitCondition.GOAL_REACHED,
        ExitCondition.TIMEOUT,
    ]


def test_a_run_stops_on_the_first_tick_at_or_past_its_time_and_runs_at_least_one() -> None:
    sim = Simulation("free_space")
    t0 = sim.time
    assert sim.advance(UNBOUNDED_TICKS, t0 + 0.0105) == (None, 11)  # 11 ms reach 10.5 ms
    assert sim.time == pytest.approx(t0 + 0.011, abs=1e-12)
    assert sim.advance(5) == (None, 5)
    assert sim.advance(UNBOUNDED_TICKS, -math.inf) == (None, 1)
    assert sim.advance(3, sim.time + 1.0) == (None, 3)  # the tick count bounds it too
    assert sim.time == pytest.approx(t0 + 0.020, abs=1e-12)
    # On a time a tick ends exactly at (read off a twin run): it stops there, not one later.
    other = Simulation("free_space")
    other.advance(5)
    assert Simulation("free_space").advance(UNBOUNDED_TICKS, other.time) == (None, 5)


def test_a_run_stops_on_the_tick_a_behavior_ends_and_reports_it_once() -> None:
    sim = Simulation("free_space")
    sim.start(behavior_for(PtwlParams(translation=[0.0, 0.0, 0.01], duration=0.5)))
    report, ticks = sim.advance(UNBOUNDED_TICKS, sim.time + 10.0)
    assert report is not None and report.exit is ExitCondition.GOAL_REACHED
    assert sim.time == pytest.approx(report.ended_at + 0.001, abs=1e-12)  # its tick ran on to the step
    assert ticks == round((sim.time - report.started_at) / 0.001)
    assert sim.advance(50) == (None, 50)  # nothing runs now: no second report


def test_a_fault_in_a_long_run_ends_the_behavior_fault_and_the_run() -> None:
    sim = Simulation("free_space")
    sim.start(behavior_for(PtwlParams(translation=[0.05, 0.0, 0.0], duration=2.0)))
    sim.advance(100)
    sim.data.qvel[2] = math.nan
    report, ticks = sim.advance(UNBOUNDED_TICKS, sim.time + 1.0)
    assert report is not None and report.exit is ExitCondition.FAULT
    assert ticks <= 2 and sim.fault_count == 1
    assert sim.time < 0.01  # reloaded: sim time starts again


def test_the_loop_reads_the_simulation_time_mujoco_keeps() -> None:
    sim = Simulation("free_space")
    view = sim.controller.mj[5]
    sim.advance(7)
    assert view[0] == sim.data.time
    sim.data.time = 12.5
    assert view[0] == 12.5


def test_the_warm_up_loads_every_entry_point_python_calls() -> None:
    """In a fresh process (each compiled function loads at its first call): after warm_up()
    every public compiled function has been loaded, from the cache, so no command pays for it."""
    code = (
        "from numba.core.registry import CPUDispatcher\n"
        "from robot_sim import tick\n"
        "from robot_sim.warm import warm_up\n"
        "warm_up()\n"
        "public = {n: f for n, f in vars(tick).items()\n"
        "          if isinstance(f, CPUDispatcher) and not n.startswith('_')}\n"
        "cold = sorted(n for n, f in public.items() if not f.signatures)\n"
        "missed = sorted(n for n, f in public.items() if sum(f.stats.cache_misses.values()))\n"
        "print(len(public), cold, missed)\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=300, env={**os.environ}
    )
    assert done.returncode == 0, done.stderr
    # 11 entry points, every one loaded, and from numba's cache (this session compiled them at its
    # start: tests/conftest.py), none compiled again
    assert done.stdout.split() == ["11", "[]", "[]"]


def test_a_reports_peaks_are_the_largest_wrench_of_any_tick_it_ran() -> None:
    sim = Simulation("surface")
    sim.start(behavior_for(SEQUENCE[0]))  # the press that breaches
    sim.advance(UNBOUNDED_TICKS)
    sim.start(behavior_for(SEQUENCE[1]))  # the RWE that relieves it: its peak is at its start
    forces, torques = [], []
    report = None
    while report is None:
        report = sim.step()
        forces.append(sim.controller.force_norm)
        torques.append(sim.controller.torque_norm)
    # measured at the start of each tick, the last one the tick it ended in
    assert report.peak_force == max(forces) and report.peak_torque == max(torques)
    assert report.peak_force > 3.0 * forces[-1]  # a real peak, not the last reading


def test_the_time_held_back_is_every_tick_a_limit_held_counted_once() -> None:
    """Joint 5 driven past its upper end (as test_controller's held-back report): the seconds a
    report gives per limit are its ticks times the period, to the millisecond."""
    sim = Simulation("free_space")
    sim.start(behavior_for(PtwlParams(rotation=[0.0, 2.2, 0.0], duration=2.0, watchdog=3.0)))
    ticks_limited: dict[str, int] = {}
    report = None
    while report is None:
        for limit in sim.controller.limits:  # what held last tick's command back
            ticks_limited[limit.value] = ticks_limited.get(limit.value, 0) + 1
        report = sim.step()
    assert ticks_limited, "nothing held the port back: the test lost its premise"
    for limit, ticks in ticks_limited.items():
        assert f"{limit} ({ticks * 0.001:.2f} s" in report.detail


def test_the_task_monitor_judges_one_window_every_10_ticks() -> None:
    sim = Simulation("surface")
    sim.start(behavior_for(SEQUENCE[0]))
    sim.advance(UNBOUNDED_TICKS)
    sim.start(behavior_for(SEQUENCE[2]))  # the dither, sliding with the monitor
    monitor = sim.monitor
    assert monitor is not None
    judged_at, last = [], monitor.last
    for k in range(300):
        if sim.step() is not None:
            break
        if monitor.last is not last:
            judged_at.append(k)
            last = monitor.last
    assert len(judged_at) >= 20
    assert set(np.diff(judged_at)) == {10}
    assert judged_at[0] == 9  # the first window: the behavior's first 10 ticks


@pytest.mark.parametrize(("wrist_rad", "every_ticks"), [(1.07, 8), (0.6, 1)])
def test_q_is_rebuilt_every_8_ticks_and_every_tick_near_a_singularity(
    wrist_rad: float, every_ticks: int
) -> None:
    """controller.py's multi-rate rule, moving slowly (5 mm/s): Q from the Jacobian every 8 ms
    at home (manipulability 2.3x the threshold), every tick at 1.5x (wrist at 0.6 rad)."""
    sim = Simulation("free_space", qpos=(0.0, 0.3, 0.2, 0.0, wrist_rad, 0.0))
    sim.start(behavior_for(PtwlParams(translation=[0.01, 0.0, 0.0], duration=2.0)))
    sim.advance(20)
    q_map = sim.controller.f[tick.QDOT_MAP : tick.QDOT_MAP + 78]
    rebuilt_at, last = [], q_map.copy()
    for k in range(64):
        sim.step()
        if not np.array_equal(q_map, last):
            rebuilt_at.append(k)
            last = q_map.copy()
    assert set(np.diff(rebuilt_at).tolist()) == {every_ticks}


@pytest.mark.parametrize(
    "params", [RweParams(duration=0.25), GripperParams(action="open", duration=0.05)], ids=["rwe", "gripper"]
)
def test_a_timed_behavior_ends_on_the_first_tick_its_duration_has_passed(params: BehaviorParams) -> None:
    sim = Simulation("free_space")
    report = sim.run_behavior(behavior_for(params))
    assert report.exit is ExitCondition.COMPLETED
    assert params.duration - 1e-9 <= report.duration < params.duration + 0.001 - 1e-9

"""The compiled loop (robot_sim/tick.py) run many ticks a call does what one call a tick does,
to the bit; it stops where Python must decide; and the warm-up loads every entry point."""

import math
import os
import subprocess
import sys

import numpy as np
import pytest

from robot_sim.behaviors import BehaviorParams, BehaviorReport, ExitCondition, behavior_for
from robot_sim.params import DitherParams, MonitorSpec, PtwlParams, RweParams
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
    view = sim.controller.mj[6]
    sim.advance(7)
    assert view[0] == sim.data.time
    sim.data.time = 12.5
    assert view[0] == 12.5


def test_the_warm_up_loads_every_entry_point_python_calls() -> None:
    """In a fresh process (each compiled function loads at its first call): after warm_up()
    every public compiled function has been loaded, so no command pays for it."""
    code = (
        "from numba.core.registry import CPUDispatcher\n"
        "from robot_sim import tick\n"
        "from robot_sim.warm import warm_up\n"
        "warm_up()\n"
        "public = {n: f for n, f in vars(tick).items()\n"
        "          if isinstance(f, CPUDispatcher) and not n.startswith('_')}\n"
        "print(len(public), sorted(n for n, f in public.items() if not f.signatures))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=300, env={**os.environ}
    )
    assert done.returncode == 0, done.stderr
    count, cold = done.stdout.split(" ", 1)
    assert int(count) == 9 and cold.strip() == "[]"

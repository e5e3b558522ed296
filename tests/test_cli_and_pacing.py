"""`ptwl` command line and real-time pacing."""

import json
import time

import pytest

from ptwl.cli import main
from robot_sim.sim import Simulation
from server.pacing import BATCH_S, MAX_LAG_S, RealTimePacer
from tests.command_line import run_ptwl
from tests.fake_clock import FakeClock


def test_pacer_steps_only_when_the_wall_clock_is_ahead() -> None:
    clock = FakeClock()
    slept: list[float] = []
    sim = Simulation("free_space")
    pacer = RealTimePacer(sim, clock=clock, sleep=slept.append)
    pacer.advance()  # lag 0: one batch
    assert sim.time == pytest.approx(BATCH_S) and slept == []
    clock.now += 0.002
    for _ in range(10):
        pacer.advance()  # the sim is 3 ms ahead of the wall clock: no steps, a sleep of 3 ms
    assert sim.time == pytest.approx(BATCH_S)
    assert slept == pytest.approx([BATCH_S - 0.002] * 10)
    clock.now -= 0.002
    for _ in range(100):  # 1 s of wall time in 10 ms ticks
        clock.now += 0.01
        while pacer.lag_s() > 0:
            pacer.advance()
    assert sim.time == pytest.approx(1.0 + BATCH_S, abs=BATCH_S)
    assert pacer.dropped_s == 0.0


def test_pacer_drops_a_backlog_instead_of_racing() -> None:
    clock = FakeClock()
    sim = Simulation("free_space")
    pacer = RealTimePacer(sim, clock=clock, sleep=lambda s: pytest.fail(f"slept {s} s while behind"))
    clock.now += 3.0  # the process was descheduled for 3 s
    pacer.advance()
    assert pacer.dropped_s == pytest.approx(3.0)
    assert sim.time == pytest.approx(BATCH_S)
    assert abs(pacer.lag_s()) < MAX_LAG_S


def test_ptwl_sim_runs_in_real_time_and_prints_status(capsys: pytest.CaptureFixture[str]) -> None:
    t0 = time.monotonic()
    assert main(["sim", "--scene", "surface", "--seconds", "1.5"]) == 0
    wall = time.monotonic() - t0
    out = capsys.readouterr().out
    assert "robot up on scene 'surface'" in out
    status = [line for line in out.splitlines() if line.startswith("t=")]
    assert len(status) == 2  # t = 0 and t = 1 s
    assert "task:" in status[-1] and "port=(" in status[-1]
    assert wall >= 1.4  # paced, not as fast as possible (it runs ~50x faster unpaced)


def test_ptwl_lists_scenes_and_presets(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["scenes"]) == 0
    assert "sleeve_on_peg" in capsys.readouterr().out
    assert main(["presets"]) == 0
    presets = json.loads(capsys.readouterr().out)
    assert set(presets["stiffness"]) >= {"stiff", "medium", "soft", "planar", "hinge"}
    assert len(presets["dither"]) == 4


def test_ptwl_rejects_an_unknown_scene() -> None:
    result = run_ptwl("up", "--scene", "moon")
    assert result.returncode == 2
    assert "invalid choice: 'moon'" in result.stderr and "sleeve_on_peg" in result.stderr

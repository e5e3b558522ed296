"""Sleeve on peg (paper 2.3.5): a tilt jams plain PTWL; a torsional push dither recovers it."""

import pytest

from robot_sim.behaviors.base import ExitCondition
from robot_sim.behaviors.dither import Dither
from robot_sim.behaviors.ptwl import Ptwl
from robot_sim.behaviors.rwe import Rwe
from robot_sim.params import DitherParams, PtwlParams, RweParams
from robot_sim.scenes import sleeve_insertion_depth
from robot_sim.sim import Simulation

TILT_RAD = 0.05  # about the tool x axis: past the clearance's tolerance once engaged
INSERT = PtwlParams(translation=[0.0, 0.0, 0.06], duration=4.0, force_threshold=25.0)


def tilted_and_jammed() -> Simulation:
    sim = Simulation("sleeve_on_peg")
    assert sleeve_insertion_depth(sim) == pytest.approx(-0.0206, abs=0.001)  # 20 mm above the peg
    tilt = sim.run_behavior(Ptwl(PtwlParams(rotation=[TILT_RAD, 0.0, 0.0], duration=1.0, preset="medium")))
    assert tilt.exit is ExitCondition.GOAL_REACHED
    jam = sim.run_behavior(Ptwl(INSERT))
    assert jam.exit is ExitCondition.WRENCH_BREACH
    assert 0.0 < sleeve_insertion_depth(sim) < 0.003  # caught at the mouth
    assert sim.run_behavior(Rwe(RweParams())).exit is ExitCondition.COMPLETED
    return sim


def test_plain_ptwl_keeps_jamming() -> None:
    sim = tilted_and_jammed()
    for _ in range(2):  # "jamming would still occur after a PTWL was sent" (paper 2.3.5)
        assert sim.run_behavior(Ptwl(INSERT)).exit is ExitCondition.WRENCH_BREACH
        sim.run_behavior(Rwe(RweParams()))
    assert not sim.task().success
    assert sleeve_insertion_depth(sim) < 0.025


def test_torsional_push_dither_recovers_the_insertion() -> None:
    sim = tilted_and_jammed()
    dither = sim.run_behavior(Dither(DitherParams(preset="torsional_push")))
    assert dither.exit is ExitCondition.GOAL_REACHED
    assert sleeve_insertion_depth(sim) > 0.015  # past the jam
    final = sim.run_behavior(Ptwl(INSERT))
    assert final.exit is ExitCondition.WRENCH_BREACH  # bottomed out in the sleeve
    task = sim.task()
    assert task.success and task.progress >= 0.035

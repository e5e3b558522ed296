"""Strategies: policies built only from PTWL, RWE and Dither (paper 2.3).

A strategy is a generator that yields the next behavior and is sent how the last one ended, so
"the subsequent state depends on the exit condition returned by the behavior" (paper 2.1).
`run_strategy` drives one on a Simulation as fast as the CPU allows; `ptwl sim --demo` drives
one paced to real time.
"""

from collections.abc import Generator

from robot_sim.behaviors.base import Behavior, BehaviorReport
from robot_sim.sim import Simulation

Strategy = Generator[Behavior, BehaviorReport, None]


def run_strategy(sim: Simulation, strategy: Strategy) -> list[BehaviorReport]:
    """Run every behavior the strategy asks for, in order; their reports."""
    reports: list[BehaviorReport] = []
    try:
        behavior = next(strategy)
        while True:
            reports.append(sim.run_behavior(behavior))
            behavior = strategy.send(reports[-1])
    except StopIteration:
        return reports

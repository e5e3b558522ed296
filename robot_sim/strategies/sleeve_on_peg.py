"""Sleeve on peg (paper 2.3.5, Table 3): insert, and recover a jam with the paper's twist dither.

Aligned, one PTWL does it: its goal lies 9 mm past the bottom of the 40 mm sleeve, so it ends
`timeout` pressing ~19 N, as in Table 3 (1 PTWL, timeout, mean peak 18.8 N). Tilted by 2-4
degrees the 0.089 mm fit jams 3-7 mm in, and every further PTWL breaches at once (the paper:
"jamming would still occur after a PTWL was sent"). The recovery, repeated while it jams:

    RWE (all axes)                 relieve the jam's wrench
    Dither torsional_push          turn +-0.1 rad about the sleeve axis at 1 Hz while advancing
                                   20 mm: the turning breaks the wedging friction and the
                                   sleeve walks in and straightens on the peg
    PTWL insert                    as before

Over tilts of +-2, 3, 4 degrees about x and y it recovers 12 of 12 with at most four rounds
(tests/test_sleeve_on_peg.py runs the grid); 1 degree does not jam at all with the `medium`
preset, whose rotational compliance absorbs it. Fixture jitter (a scene seed) is +-1 mm in x
and y, inside the 1.5 mm chamfer's capture range: every seed inserts with the first PTWL.
"""

from collections.abc import Callable

from robot_sim.behaviors import Dither, ExitCondition, Ptwl, Rwe
from robot_sim.params import DitherParams, PtwlParams, RweParams
from robot_sim.strategies import Strategy

INSERT = PtwlParams(translation=[0.0, 0.0, 0.07], duration=7.0, force_threshold=25.0)
RELIEVE = RweParams(duration=1.0)
TWIST = DitherParams(preset="torsional_push")
MAX_RECOVERIES = 4


def sleeve_insertion(task_done: Callable[[], bool]) -> Strategy:
    """Insert; while the insertion breaches (a jam) and the task is not done, recover and retry."""
    report = yield Ptwl(INSERT)
    for _ in range(MAX_RECOVERIES):
        if report.exit is not ExitCondition.WRENCH_BREACH or task_done():
            return
        yield Rwe(RELIEVE)
        yield Dither(TWIST)
        report = yield Ptwl(INSERT)

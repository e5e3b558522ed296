"""Quick-disconnect coupling (paper 2.3.6): a snap fit that needs 25-30 N to latch.

    insert    PTWL 60 mm down the tool axis, force threshold 35 N: above the 25-30 N the latch
              needs (the default 20 N would stop at the collar), below what pressing on the
              latched seat builds, so the PTWL ends soon after the snap
              -> the port went past SEATED_M: latched; relieve
              -> it stopped short (a jam at the mouth, or the collar not pushed through): recover
    recover   RWE (all axes), Dither torsional_push (turn while advancing), insert again;
              after MAX_RECOVERIES: failed
    relieve   RWE: the seating force goes, the latch holds; completed

Depth is judged by how far the port has travelled down the tool axis since the start (the
mouth is nominally 20 mm below home, the latched seat 40 mm), never by the predicate.
"""

from robot_sim.behaviors import BehaviorReport, Pose
from robot_sim.params import DitherParams, PtwlParams, RweParams
from robot_sim.policies.base import Decision, Finish, Policy, Step
from robot_sim.policies.travel import travel_down_tool_axis_m

# `medium` named: a state machine must not inherit whatever gains the last operator left.
INSERT = PtwlParams(translation=[0.0, 0.0, 0.06], duration=6.0, force_threshold=35.0, preset="medium")
RELIEVE = RweParams(duration=1.0)
TWIST = DitherParams(preset="torsional_push")
MAX_RECOVERIES = 3
SEATED_M = 0.039  # [m] travel from home past which the nipple has pushed the collar through


class QuickConnect(Policy):
    task = "quick_connect"
    summary = (
        "insert at 35 N (the latch needs 25-30 N); on a jam relieve, twist-dither, insert again; relieve"
    )

    def __init__(self) -> None:
        self.home: Pose | None = None
        self.recoveries = 0
        self.pending: list[Step] = []
        self.seated = False
        self.seat_m = 0.0  # [m] travel when it seated

    def first(self, port: Pose) -> Step:
        self.home = port
        return Step(INSERT, "insert: PTWL 60 mm down the tool axis at up to 35 N, enough to push the latch")

    def next(self, report: BehaviorReport) -> Decision:
        assert self.home is not None
        if self.seated:
            return Finish(True, f"latched at {1000 * self.seat_m:.1f} mm and relieved ({report.exit})")
        if self.pending:
            return self.pending.pop(0)
        travel = travel_down_tool_axis_m(self.home, report.final_port)
        if travel >= SEATED_M:
            self.seated, self.seat_m = True, travel
            return Step(RELIEVE, f"seated {1000 * travel:.1f} mm down ({report.exit}): relieve the press")
        if self.recoveries == MAX_RECOVERIES:
            return Finish(False, f"still short at {1000 * travel:.1f} mm after {MAX_RECOVERIES} recoveries")
        self.recoveries += 1
        depth = f"{1000 * travel:.1f} mm down"
        why = f"short {self.recoveries}: {report.exit} at {report.peak_force:.1f} N, {depth}"
        self.pending = [Step(TWIST, f"{why}; twist-dither to free it"), Step(INSERT, "insert again")]
        return Step(RELIEVE, f"{why}; relieve the wrench first")

"""Quick-disconnect coupling (paper 2.3.6): a snap fit that needs 25-30 N to latch.

    insert    PTWL 60 mm down the tool axis, force threshold 35 N: above the 25-30 N the latch
              needs (the default 20 N would stop at the collar), below what pressing on the
              latched seat builds, so the PTWL ends soon after the snap
              -> the port went past SEATED_M: latched; relieve
              -> it stopped short (a jam at the mouth, or the collar not pushed through): recover
    recover   RWE (all axes), Dither torsional_push (turn while advancing, until the port has
              gone 4-5 mm further in), RWE, insert again; after `max_recoveries` (3): failed
    relieve   RWE: the seating force goes, the latch holds; completed

Depth is judged by how far the port has travelled down the tool axis since the start (the
mouth is nominally 20 mm below home, the latched seat 40 mm), never by the predicate.
"""

from pydantic import Field

from robot_sim.behaviors import BehaviorReport
from robot_sim.params import PtwlParams
from robot_sim.policies.base import Decision, Finish, Step
from robot_sim.policies.insertion import RELIEVE, InsertionPolicy, InsertionSettings

SEATED_M = 0.039  # [m] travel from home past which the nipple has pushed the collar through


class QuickConnectSettings(InsertionSettings):
    insert_force_threshold: float = Field(
        35.0, gt=0.0, le=500.0, description="[N] the insertion PTWL's; the latch needs 25-30 N"
    )


class QuickConnect(InsertionPolicy):
    task = "quick_connect"
    summary = (
        "insert at 35 N (the latch needs 25-30 N); on a jam relieve, twist-dither, relieve, "
        "insert again; relieve"
    )
    settings_model = QuickConnectSettings
    # `medium` named: a state machine must not inherit whatever gains the last operator left.
    INSERT = PtwlParams(translation=[0.0, 0.0, 0.06], duration=6.0, force_threshold=35.0, preset="medium")

    def __init__(self, overrides: dict[str, object] | None = None) -> None:
        super().__init__(overrides)
        self.seated = False
        self.seat_m = 0.0  # [m] travel when it seated

    def opening(self) -> Step:
        threshold = self.insert.force_threshold
        return self.stage(
            "insert",
            self.insert,
            f"insert: PTWL 60 mm down the tool axis at up to {threshold:g} N, to push the latch",
        )

    def next(self, report: BehaviorReport) -> Decision:
        if self.seated:
            return Finish(True, f"latched at {1000 * self.seat_m:.1f} mm and relieved ({report.exit})")
        if self.pending:
            return self.pending.pop(0)
        travel = self.travel_m(report.final_port)
        if travel >= SEATED_M:
            self.seated, self.seat_m = True, travel
            return Step(RELIEVE, f"seated {1000 * travel:.1f} mm down ({report.exit}): relieve the press")
        return self.recover(
            f"short: {report.exit} at {report.peak_force:.1f} N, {1000 * travel:.1f} mm down", travel
        )


INSERT = QuickConnect.INSERT

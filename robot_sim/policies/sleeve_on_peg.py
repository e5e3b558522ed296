"""Sleeve on peg (paper 2.3.5, Table 3): insert, and recover a jam with the paper's twist dither.

Aligned, one PTWL does it: its goal lies 9 mm past the bottom of the 40 mm sleeve, so it ends
`timeout` pressing ~19 N, as in Table 3 (1 PTWL, timeout, mean peak 18.8 N). Tilted by 2-4
degrees the 0.089 mm fit jams 3-7 mm in, and every further PTWL breaches at once (the paper:
"jamming would still occur after a PTWL was sent"). The machine:

    insert    PTWL 70 mm down the tool axis     -> ended without a breach: bottomed, completed
                                                -> breached past INSERTED_M: in far enough, completed
                                                -> breached short of it: a jam, recover
    recover   RWE (all axes)                    relieve the jam's wrench
              Dither torsional_push             turn +-0.1 rad about the sleeve axis at 1 Hz while
                                                advancing 20 mm: the turning breaks the wedging
                                                friction and the sleeve walks in and straightens;
                                                it ends once the port has gone 4-5 mm further in
              RWE (all axes)                    relieve the twist's push
              then insert again; after `max_recoveries` (4) jams in a row: failed

It judges depth only by how far the port has travelled down the tool axis since the start (the
sleeve's mouth is nominally 21 mm below home), never by the simulator's predicate.
"""

from pydantic import Field

from robot_sim.behaviors import BehaviorReport, ExitCondition, Pose
from robot_sim.params import PtwlParams
from robot_sim.policies.base import Decision, Finish, Step
from robot_sim.policies.insertion import InsertionPolicy, InsertionSettings

INSERTED_M = 0.050  # [m] travel down the tool axis from home: sleeve >= 30 mm over the peg


class SleeveSettings(InsertionSettings):
    max_recoveries: int = Field(4, ge=0, le=10, description="recovery rounds before it gives up")
    insert_force_threshold: float = Field(
        25.0, gt=0.0, le=500.0, description="[N] the insertion PTWL's; a jam breaches it"
    )


class SleeveOnPeg(InsertionPolicy):
    task = "sleeve_on_peg"
    summary = "insert (PTWL); on a jam relieve (RWE), twist-dither, relieve and insert again, up to 4 times"
    settings_model = SleeveSettings
    # `medium` named: a state machine must not inherit whatever gains the last operator left.
    INSERT = PtwlParams(translation=[0.0, 0.0, 0.07], duration=7.0, force_threshold=25.0, preset="medium")

    def first(self, port: Pose) -> Step:
        self.home = port
        return Step(self.insert, "insert: PTWL 70 mm down the tool axis, 9 mm past the sleeve's bottom")

    def next(self, report: BehaviorReport) -> Decision:
        if self.pending:  # inside a recovery: its next behavior, whatever this one's exit
            return self.pending.pop(0)
        travel = self.travel_m(report.final_port)
        if report.exit is not ExitCondition.WRENCH_BREACH:
            return Finish(True, f"insertion ended {report.exit} with no breach, {1000 * travel:.1f} mm down")
        if travel >= INSERTED_M:
            return Finish(
                True, f"breached {1000 * travel:.1f} mm down: past the {1000 * INSERTED_M:.0f} mm mark"
            )
        return self.recover(
            f"jam: breached {report.peak_force:.1f} N only {1000 * travel:.1f} mm down", travel
        )


INSERT = SleeveOnPeg.INSERT

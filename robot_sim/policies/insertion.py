"""What the insertion machines share (sleeve on peg, quick connect): one insertion PTWL whose
force threshold is a setting, the count of recovery rounds (`out_of_rounds`), and the paper's
twist-dither recovery when it stops short (`recover`, the quick connect's; the sleeve, in a fit as
stiff as the rigid one, backs out and re-aims instead: sleeve_on_peg.py):

    RWE (all axes)              relieve the jam's wrench
    Dither torsional_push       turn while advancing: breaks the wedging friction; ends once the
                                port has walked 4-5 mm further in (`progress` 5 mm, within the
                                travel's 1 mm tolerance), or at its watchdog
    RWE (all axes)              relieve what the dither's push left: inserting again from it
                                breached at once (17 of 36 times over the sleeve's grid, 28-33 N)
    the insertion again         after `max_recoveries` rounds: failed
"""

from typing import ClassVar

from pydantic import Field

from robot_sim.behaviors import Pose
from robot_sim.params import DitherParams, PtwlParams, RweParams
from robot_sim.policies.base import Decision, Finish, PolicySettings, StagedPolicy, Step
from robot_sim.policies.travel import travel_down_tool_axis_m

RELIEVE = RweParams(duration=1.0)
# The twist ends once the port has walked 4-5 mm further in (the jam has given), not on its 11 s
# watchdog: over the sleeve's tilt grid 4 of 35 twists ran to the watchdog, 33 of 36 before.
TWIST = DitherParams(preset="torsional_push", progress=0.005)


class InsertionSettings(PolicySettings):
    insert_force_threshold: float = Field(25.0, gt=0.0, le=500.0, description="[N] the insertion PTWL's")


class InsertionPolicy(StagedPolicy):
    """An insertion PTWL (`INSERT`, its threshold from the settings) and the recovery rounds."""

    INSERT: PtwlParams
    settings_model: ClassVar[type[PolicySettings]] = InsertionSettings
    settings: InsertionSettings

    def __init__(self, overrides: dict[str, object] | None = None) -> None:
        super().__init__(overrides)
        self.insert = self.INSERT.model_copy(update={"force_threshold": self.settings.insert_force_threshold})
        self.recoveries = 0
        self.pending: list[Step] = []

    def travel_m(self, port: Pose) -> float:
        return travel_down_tool_axis_m(self.start, port)

    def out_of_rounds(self, travel_m: float) -> Finish | None:
        """Failed, once `max_recoveries` rounds have not got it in; else None (counted: one more)."""
        if self.recoveries == self.settings.max_recoveries:
            return Finish(
                False, f"still short {1000 * travel_m:.1f} mm down after {self.recoveries} recoveries"
            )
        self.recoveries += 1
        return None

    def recover(self, why: str, travel_m: float) -> Decision:
        """Another recovery round (relieve, twist, relieve, insert), or give up after the last."""
        if (gave_up := self.out_of_rounds(travel_m)) is not None:
            return gave_up
        why = f"{why} ({self.recoveries})"
        self.pending = [
            Step(TWIST, f"{why}; twist-dither to free it"),
            Step(RELIEVE, "relieve what the dither's push left"),
            Step(self.insert, "insert again"),
        ]
        return Step(RELIEVE, f"{why}; relieve the wrench first")

"""The insertion PTWL whose force threshold is a setting, and the count of recovery rounds
(`out_of_rounds`): the sleeve on peg's (sleeve_on_peg.py). The quick connect's and the plug's
twist-dither recovery is written in their machine files (robot_sim/machines/builtin)."""

from typing import ClassVar

from pydantic import Field

from robot_sim.behaviors import Pose
from robot_sim.params import PtwlParams, RweParams
from robot_sim.policies.base import Finish, PolicySettings, StagedPolicy
from robot_sim.policies.travel import travel_down_tool_axis_m

RELIEVE = RweParams(duration=1.0)


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

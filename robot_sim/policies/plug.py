"""Plug insertion (paper 2.3.7, Fig. 10): "the attractor is placed somewhere below the outlet
surface until contact is detected. Next the attractor is moved to only slightly below the
surface and translated in the direction of the outlet until the force in the y-direction
crosses the contact threshold. Then the attractor can be placed deeply into the socket."

    approach  PTWL 40 mm down at up to 6 N
              -> the prongs went past the face: already over the holes; insert
              -> stopped on the face: slide
    slide     PTWL 12 mm along +y (base axes), 3 mm below the face (~6 N down), threshold
              12 N: over the holes the prongs drop in and the slot's far wall stops them (a
              breach, the lateral force). No drop within 12 mm: the outlet is the other way;
              slide 24 mm along -y. Still no drop: failed.
    insert    PTWL 25 mm down at up to 15 N: the plug's body meets the face (a breach)
              -> short of full depth: the paper's recovery (insertion.py)
    relieve   RWE; completed

The machine does not know which way along y the outlet is (the operator sees it; the scene's
seeds put it up to 10 mm either way). Depth is judged by the port's travel down the tool axis
since the start (the face nominally 15 mm below home), never by the predicate.
"""

from pydantic import Field

from robot_sim.behaviors import BehaviorReport
from robot_sim.params import PtwlParams
from robot_sim.policies.base import Decision, Finish, Step
from robot_sim.policies.insertion import RELIEVE, InsertionPolicy, InsertionSettings

# `medium` named: a state machine must not inherit whatever gains the last operator left.
APPROACH = PtwlParams(translation=[0.0, 0.0, 0.04], duration=4.0, force_threshold=6.0, preset="medium")
FACE_M = 0.015  # [m] nominal travel from home to the outlet's face
DROPPED_M = FACE_M + 0.0015  # past this the prongs are in the holes
INSERTED_M = FACE_M + 0.0145  # the plug's body on the face (prongs 16 mm)
SLIDE_M = 0.012  # [m] more than the largest offset the scene's seeds give (10 mm)
SLIDE_PRESS_M = 0.003  # [m] the attractor this far below the face while sliding: ~6 N down
SLIDE_SPEED_M_S = 0.003  # slow enough for the prongs to drop ~1.5 mm while over a 1 mm window


def slide(y_m: float) -> PtwlParams:
    return PtwlParams(
        translation=[0.0, y_m, -SLIDE_PRESS_M],
        frame="base",
        duration=abs(y_m) / SLIDE_SPEED_M_S,
        # The attractor ends below the face, out of reach: a slide that finds no hole ends
        # on the watchdog, this soon after the attractor stops.
        watchdog=abs(y_m) / SLIDE_SPEED_M_S + 0.5,
        force_threshold=12.0,
        preset="medium",
    )


class PlugSettings(InsertionSettings):
    insert_force_threshold: float = Field(
        15.0,
        gt=0.0,
        le=500.0,
        description="[N] the insertion PTWL's: ends when the plug's body meets the face",
    )


class Plug(InsertionPolicy):
    task = "plug"
    summary = (
        "down to the face; slide along y pressing lightly until the prongs drop in and stop; insert; relieve"
    )
    settings_model = PlugSettings
    INSERT = PtwlParams(translation=[0.0, 0.0, 0.025], duration=3.0, force_threshold=15.0, preset="medium")

    def __init__(self, overrides: dict[str, object] | None = None) -> None:
        super().__init__(overrides)
        self.slides: list[float] = []  # [m] along y, in order
        self.inserting = False
        self.relieving = False

    def opening(self) -> Step:
        return self.stage(
            "approach", APPROACH, "approach: PTWL 40 mm down at up to 6 N, to find the outlet's face"
        )

    def next(self, report: BehaviorReport) -> Decision:
        travel = self.travel_m(report.final_port)
        depth = f"{1000 * travel:.1f} mm down"
        if self.relieving:
            return Finish(True, f"prongs in and relieved ({report.exit}, {depth})")
        if self.pending:
            return self.pending.pop(0)
        if travel >= INSERTED_M:
            self.relieving = True
            return Step(RELIEVE, f"fully in ({depth}, {report.exit} at {report.peak_force:.1f} N): relieve")
        if self.inserting:
            return self.recover(f"short: {report.exit} at {report.peak_force:.1f} N, {depth}", travel)
        if travel >= DROPPED_M:
            self.inserting = True
            return Step(self.insert, f"prongs in the holes ({depth}, {report.exit}): insert deep")
        if travel < FACE_M - 0.004:
            return Finish(False, f"{report.exit} {depth}: above where the face should be")
        if not self.slides:
            self.slides.append(SLIDE_M)
            return Step(slide(SLIDE_M), f"on the face ({depth}): slide 12 mm along +y pressing lightly")
        if len(self.slides) == 1:
            self.slides.append(-2 * SLIDE_M)
            return Step(
                slide(-2 * SLIDE_M), f"no hole along +y ({report.exit}, {depth}): slide 24 mm back along -y"
            )
        return Finish(False, f"no hole within 12 mm either way along y ({depth})")

"""Wide, shallow lid (paper 2.3.9, Fig. 12): a 200 mm lid into a pan's lip, the pan off the tool
axis by more than the 2.5 mm play, in a direction the machine does not know.

    approach  PTWL down at up to 8 N until contact
              -> on the lip (stopped ~20 mm down): read where
    read      PTWL to 3 mm below the port for 0.5 s (pressing ~6 N): the wrench at a breach
              is an impact's, blurred by the lid's own inertia; held still, the contact under
              the lid's edge shows in the torque about the port, r = (-tau_y, tau_x) / f_z
              (base axes). The paper's operator sees it as the lid's tilt. Slide the other way.
    slide     PTWL 15 mm across (base axes) toward the centre, 6 mm below the lip's top so the
              lid drops in once its edge clears the lip; the far wall stops it (a breach)
              -> inside (more than 3.5 mm below the lip's top): seat; still on the lip: read again
    seat      PTWL 20 mm down at up to 15 N onto the pan's floor
    relieve   RWE once on the floor; completed

Depth is judged by the port's travel down the tool axis since the start (the lip's top is
nominally 20 mm below home, the floor 35 mm), never by the predicate.
"""

import math

import numpy as np
from pydantic import Field

from robot_sim.behaviors import BehaviorReport, Pose
from robot_sim.params import PtwlParams, RweParams
from robot_sim.policies.base import Decision, Finish, Policy, PolicySettings, Step
from robot_sim.policies.travel import travel_down_tool_axis_m

# `medium` named: a state machine must not inherit whatever gains the last operator left.
APPROACH = PtwlParams(translation=[0.0, 0.0, 0.05], duration=4.0, force_threshold=8.0, preset="medium")
READ = PtwlParams(
    translation=[0.0, 0.0, 0.003], duration=0.5, watchdog=1.0, force_threshold=15.0, preset="medium"
)
SEAT = PtwlParams(translation=[0.0, 0.0, 0.02], duration=2.0, force_threshold=15.0, preset="medium")
RELIEVE = RweParams(duration=1.0)
SLIDE_M = 0.015  # [m] across: more than the largest offset the scene's seeds give (12 mm)
SLIDE_PRESS_M = 0.006  # [m] the attractor this far below the port while sliding: ~12 N down
LIP_M = 0.020  # [m] nominal travel from home to the lip's top
INSIDE_M = LIP_M + 0.0035  # past this the lid is inside the lip (on the lip it rests at ~20 mm)
ON_FLOOR_M = 0.033  # the floor is at 35 mm


class LidSettings(PolicySettings):
    max_recoveries: int = Field(3, ge=0, le=10, description="slides across the lip before it gives up")


def slide_away_from(report: BehaviorReport) -> tuple[PtwlParams, str]:
    """A base-frame slide away from where the lid touches, from the torque about the port."""
    fz, tau_x, tau_y = report.final_wrench[2], report.final_wrench[3], report.final_wrench[4]
    contact = np.array([-tau_y, tau_x]) / max(fz, 1e-6)  # [m] where the lid touches, from the port
    away = -contact / max(float(np.linalg.norm(contact)), 1e-9)
    params = PtwlParams(
        translation=[SLIDE_M * away[0], SLIDE_M * away[1], -SLIDE_PRESS_M],
        frame="base",
        duration=3.0,
        force_threshold=15.0,
        preset="medium",
    )
    heading = math.degrees(math.atan2(away[1], away[0]))
    return (
        params,
        f"touching {1000 * float(np.linalg.norm(contact)):.0f} mm off the port (torque), "
        f"slide toward {heading:.0f} deg",
    )


class Lid(Policy):
    task = "lid"
    summary = (
        "down to contact; slide away from the contact the torque shows until the lid drops in; seat; relieve"
    )

    settings_model = LidSettings
    settings: LidSettings

    def __init__(self, overrides: dict[str, object] | None = None) -> None:
        super().__init__(overrides)
        self.home: Pose | None = None
        self.slides = 0
        self.seats = 0
        self.relieving = False
        self.read = False  # the last step was a READ: its wrench is the settled one

    def first(self, port: Pose) -> Step:
        self.home = port
        return Step(APPROACH, "approach: PTWL 50 mm down at up to 8 N, to find the lip or the floor")

    def next(self, report: BehaviorReport) -> Decision:
        assert self.home is not None
        travel = travel_down_tool_axis_m(self.home, report.final_port)
        depth = f"{1000 * travel:.1f} mm down"
        if self.relieving:
            return Finish(True, f"seated on the floor and relieved ({report.exit}, {depth})")
        if travel >= ON_FLOOR_M:
            self.relieving = True
            return Step(RELIEVE, f"on the floor {depth}: relieve the press")
        if travel >= INSIDE_M:
            if self.seats == 2:
                return Finish(False, f"inside the lip but not down on the floor ({depth})")
            self.seats += 1
            return Step(SEAT, f"inside the lip ({depth}): press down onto the floor")
        if travel >= LIP_M - 0.006:  # on the lip, whatever the exit: read where, then slide
            if not self.read:
                self.read = True
                return Step(
                    READ, f"on the lip ({depth}, {report.exit}): hold the contact still to read where it is"
                )
            self.read = False
            if self.slides == self.settings.max_recoveries:
                return Finish(False, f"still on the lip ({depth}) after {self.slides} slides")
            self.slides += 1
            params, why = slide_away_from(report)
            return Step(params, f"on the lip ({depth}): {why}")
        return Finish(False, f"{report.exit} {depth}: above where the lip should be")

"""Opening and closing a latched door (paper 2.3.8, Fig. 11): "The handle can be turned by
imposing a rotational displacement of the soft attractor. Subsequently, the door can be opened
by setting all virtual translational stiffnesses to near zero, then imposing an attractor
rotation roughly parallel to the door hinge ... the robot conformed to the hinge's kinematic
constraint." Closing is the same in reverse.

    turn      PTWL 0.5 rad about the tool axis (`medium`): the knob withdraws the latch
              -> turned less than 0.4 rad: failed (the knob is stuck)
    open      PTWL 0.95 rad about the base -y (the hinge's rough direction), `hinge` preset
              (5 N/m translation: the port follows the hinge's arc, wherever the hinge is)
              -> the tool axis swung >= 46 deg: close; less: open again (`max_recoveries`)
    close     PTWL back by the angle opened and 0.05 rad more, `hinge`: shut against the stop
    relieve   RWE: the press against the stop goes
    let go    PTWL back about the tool axis: the knob returns and the latch can catch
    check     PTWL 0.2 rad open at up to 1 N m: a latched door does not move (< 2 deg)
    relieve   RWE; completed

The machine knows the hinge's direction roughly (along the base y) but not where it is; the
door's angle is judged by how far the tool's axis has swung, the knob's turn by how far the
tool has turned about its axis, never by the predicate.
"""

import math

from pydantic import Field

from robot_sim.behaviors import BehaviorReport
from robot_sim.params import PtwlParams, RweParams
from robot_sim.policies.base import Decision, Finish, PolicySettings, StagedPolicy, Step
from robot_sim.policies.travel import tool_axis_tilt_rad, twist_about_tool_axis_rad

TURN_RAD = 0.5
TURNED_RAD = 0.4  # the latch is withdrawn at 0.35 rad (20 deg)
OPEN_RAD = 0.95
SHUT_RAD = math.radians(2.0)
RELIEVE = RweParams(duration=1.0)
# Slow: with `hinge`'s 1000 N s/m, the port moves 1 mm/s per newton of pull along the arc.
SWING_S = 10.0


def swing(about_minus_y_rad: float, torque_threshold_nm: float, duration_s: float = SWING_S) -> PtwlParams:
    """A rotation of the attractor about the base -y (the hinge's rough direction), translation
    left to the hinge: `hinge` gains, a goal that needs the orientation only."""
    return PtwlParams(
        rotation=[0.0, -about_minus_y_rad, 0.0],
        frame="base",
        duration=duration_s,
        preset="hinge",
        position_tolerance=0.3,
        orientation_tolerance=0.05,
        force_threshold=20.0,
        torque_threshold=torque_threshold_nm,
    )


class DoorSettings(PolicySettings):
    open_deg: float = Field(46.0, ge=10.0, le=90.0, description="[deg] how far to open before closing")


class Door(StagedPolicy):
    task = "door"
    summary = "turn the knob; swing open about the hinge with soft translation; swing shut; let go; check"
    settings_model = DoorSettings
    settings: DoorSettings

    def __init__(self, overrides: dict[str, object] | None = None) -> None:
        super().__init__(overrides)
        self.turned_rad = 0.0
        self.opened_rad = 0.0
        self.opens = 0

    def opening(self) -> Step:
        turn = PtwlParams(rotation=[0.0, 0.0, TURN_RAD], duration=2.0, preset="medium")
        return self.stage("turn", turn, "turn the knob 0.5 rad about the tool axis to withdraw the latch")

    def next(self, report: BehaviorReport) -> Decision:
        tilt = tool_axis_tilt_rad(self.start, report.final_port)
        angle = f"door at {math.degrees(tilt):.1f} deg"
        if self.last == "turn":
            self.turned_rad = twist_about_tool_axis_rad(self.start, report.final_port)
            if self.turned_rad < TURNED_RAD:
                return Finish(
                    False, f"the knob turned only {math.degrees(self.turned_rad):.0f} deg ({report.exit})"
                )
            return self.stage(
                "open",
                swing(OPEN_RAD, 3.0),
                f"knob turned {math.degrees(self.turned_rad):.0f} deg: swing it open, translation soft",
            )
        if self.last == "open":
            self.opened_rad = tilt
            if tilt >= math.radians(self.settings.open_deg):
                return self.stage(
                    "close", swing(-(tilt + 0.05), 2.0), f"opened ({angle}, {report.exit}): swing it shut"
                )
            if self.opens == self.settings.max_recoveries:
                return Finish(
                    False, f"opened only to {math.degrees(tilt):.1f} deg after {self.opens + 1} tries"
                )
            self.opens += 1
            return self.stage(
                "open", swing(OPEN_RAD - tilt, 3.0), f"only {angle} ({report.exit}): open again"
            )
        if self.last == "close":
            if tilt > SHUT_RAD:
                return Finish(False, f"not shut: {angle} ({report.exit})")
            return self.stage("relieve", RELIEVE, f"shut ({angle}, {report.exit}): relieve the press")
        if self.last == "relieve":
            let_go = PtwlParams(rotation=[0.0, 0.0, -self.turned_rad], duration=2.0, preset="medium")
            return self.stage("let go", let_go, "let the knob back so the latch catches")
        if self.last == "let go":
            return self.stage(
                "check", swing(0.2, 1.0, 2.0), "check the latch: pull it open 0.2 rad at up to 1 N m"
            )
        if self.last == "check":
            if tilt > SHUT_RAD:
                return Finish(False, f"the latch did not hold: {angle} ({report.exit})")
            return self.stage("done", RELIEVE, f"latched: it did not move ({angle}, {report.exit}); relieve")
        return Finish(True, f"opened to {math.degrees(self.opened_rad):.1f} deg, shut and latched")

"""Berthing (paper 2.3.1, Fig. 3b): "If the satellite is misaligned when first contact occurs,
then the robot will measure a substantial torque ... the robot slides the satellite in the
direction that was determined by the torque measurement ... At the same time, it continues to
apply forward pressure ... the berthing can be completed by simply pressing forward."

    approach  PTWL 60 mm forward (base +x) at up to 15 N (F_thresh), `planar` preset
              -> no contact: failed
              -> |tau_z| at first contact < 0.2 N m (tau_thresh): aligned; press
              -> otherwise slide toward the side tau_z's sign gives
    slide     PTWL 12 mm sideways toward the posts and 4 mm forward (keeping the pressure),
              at up to 15 N: the posts run down the V clamps' flanks
    relieve   RWE: the slide's sideways load goes, the sled free to square up
    press     PTWL 10 mm forward at up to 15 N; relieve; again until a press (the second or
              later) advances the sled less than 1 mm (both clamps seated; at most
              `max_recoveries` + 1 presses)
    relieve   RWE; completed

The machine knows only that the posts are ahead (base +x); which way they are off, it learns
from the torque at first contact, never from the predicate.
"""

import numpy as np

from robot_sim.behaviors import BehaviorReport, ExitCondition
from robot_sim.params import PtwlParams, RweParams
from robot_sim.policies.base import Decision, Finish, StagedPolicy, Step

F_THRESH_N = 15.0
TAU_THRESH_NM = 0.2
SEATED_ADVANCE_M = 0.001  # a press that moves the sled less than this: seated
RELIEVE = RweParams(duration=1.0)


def planar(translation_m: list[float], duration_s: float) -> PtwlParams:
    return PtwlParams(
        translation=translation_m,
        frame="base",
        duration=duration_s,
        preset="planar",
        force_threshold=F_THRESH_N,
        torque_threshold=5.0,
    )


APPROACH = planar([0.06, 0.0, 0.0], 6.0)
PRESS = planar([0.01, 0.0, 0.0], 3.0)


def slide(toward_y: float) -> PtwlParams:
    return planar([0.004, toward_y * 0.012, 0.0], 4.0)


class Berthing(StagedPolicy):
    task = "berthing"
    summary = (
        "press onto the posts; slide toward the side the first contact's torque shows; press until seated"
    )

    def __init__(self, overrides: dict[str, object] | None = None) -> None:
        super().__init__(overrides)
        self.presses = 0
        self.pressed_from_x = 0.0  # [m] base x of the port before the last press

    def opening(self) -> Step:
        return self.stage("approach", APPROACH, "approach: PTWL 60 mm forward at up to 15 N, onto the posts")

    def _press(self, report: BehaviorReport, why: str) -> Step:
        self.pressed_from_x = report.final_port.position[0]
        self.presses += 1
        return self.stage("press", PRESS, why)

    def next(self, report: BehaviorReport) -> Decision:
        if self.last == "approach":
            if report.exit is not ExitCondition.WRENCH_BREACH:
                return Finish(False, f"no contact within 60 mm ({report.exit})")
            tau_z = report.final_wrench[5]
            if abs(tau_z) < TAU_THRESH_NM:
                return self._press(report, f"contact, tau_z {tau_z:+.2f} N m: aligned; press forward")
            toward = float(np.sign(tau_z))
            return self.stage(
                "slide",
                slide(toward),
                f"contact, tau_z {tau_z:+.2f} N m: slide toward {'+' if toward > 0 else '-'}y, pressing",
            )
        if self.last == "slide":
            return self.stage("relieve", RELIEVE, f"slid ({report.exit}): relieve before pressing")
        if self.last == "press":
            advance = report.final_port.position[0] - self.pressed_from_x
            # Never on the first press: its relieve lets the sled square up, and the next press
            # can still draw it in.
            name = "done" if advance < SEATED_ADVANCE_M and self.presses >= 2 else "relieve"
            return self.stage(
                name, RELIEVE, f"press advanced {1000 * advance:.1f} mm ({report.exit}): relieve"
            )
        if self.last == "relieve":
            if self.presses > self.settings.max_recoveries:
                return Finish(False, f"still advancing after {self.presses} presses")
            return self._press(report, "press forward")
        return Finish(True, f"seated: the last press advanced less than 1 mm, after {self.presses} presses")

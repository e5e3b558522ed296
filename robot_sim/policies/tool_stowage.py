"""Tool stowage (paper 2.3.4): "coming into contact with the upper stop of the stowage bay,
rotating the lock open, bottoming out within the stowage bay, and then stowing the tool by
rotating the lock closed. The gripper then releases the tool before leaving the bay area."

    approach  PTWL 30 mm down at up to 10 N: the tool's legs on the bay's tabs (upper stop)
              -> went past them (> 15 mm down): already between the tabs; bottom out
    unlock    PTWL 0.8 rad about the tool axis: the legs over the gaps between the tabs
              -> turned less than 0.6 rad: failed
    bottom    PTWL 30 mm down at up to 10 N: the tool on the bay's floor
              -> stopped short of it (< 18 mm down): failed
    lock      PTWL back to the start's turn: the legs under the tabs (the lock's spring helps)
    release   open the gripper
    leave     PTWL 30 mm up -> the goal reached: completed
"""

from robot_sim.behaviors import BehaviorReport, ExitCondition
from robot_sim.policies.base import Decision, Finish, StagedPolicy, Step
from robot_sim.policies.tool_bay import OPEN, TURN_OPEN_RAD, down, lock_turned, turn, turned_open_rad, up
from robot_sim.policies.travel import travel_down_tool_axis_m

APPROACH = down(0.03)
PAST_STOP_M = 0.015  # [m] travel: the legs are below the tabs' top
BOTTOM_M = 0.018  # [m] travel: the tool on the floor (20 mm down nominally)


class ToolStowage(StagedPolicy):
    task = "tool_stowage"
    summary = "down onto the lock; turn it open; bottom out; turn it shut; open the gripper; leave"

    def opening(self) -> Step:
        return self.stage(
            "approach", APPROACH, "approach: PTWL 30 mm down at up to 10 N, onto the lock's upper stop"
        )

    def next(self, report: BehaviorReport) -> Decision:
        depth_m = travel_down_tool_axis_m(self.start, report.final_port)
        depth = f"{1000 * depth_m:.1f} mm down"
        if self.last == "approach":
            if depth_m >= PAST_STOP_M:
                return self.stage("bottom", down(0.03), f"past the tabs already ({depth}): bottom out")
            return self.stage(
                "unlock",
                turn(-TURN_OPEN_RAD),
                f"on the upper stop ({depth}, {report.exit}): turn the lock open",
            )
        if self.last == "unlock":
            opened, turned = lock_turned(self.start, report)
            if not opened:
                return Finish(False, f"the lock turned only {turned} ({report.exit})")
            return self.stage("bottom", down(0.03), f"lock open ({turned}): bottom out")
        if self.last == "bottom":
            if depth_m < BOTTOM_M:
                return Finish(False, f"stopped short of the floor ({depth}, {report.exit})")
            return self.stage(
                "lock", turn(turned_open_rad(self.start, report)), f"bottomed ({depth}): turn the lock shut"
            )
        if self.last == "lock":
            return self.stage(
                "release", OPEN, f"locked ({lock_turned(self.start, report)[1]}): open the gripper"
            )
        if self.last == "release":
            return self.stage("leave", up(0.03), f"{report.detail}: leave the bay")
        if report.exit is ExitCondition.GOAL_REACHED:
            return Finish(True, "stowed, locked and let go")
        return Finish(False, f"could not leave the bay ({report.exit} at {report.peak_force:.1f} N)")

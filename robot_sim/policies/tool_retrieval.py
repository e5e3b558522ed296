"""Tool retrieval (paper 2.3.3): "First, the robot must bottom its contact with the tool before
engaging the gripper to grab the tool. Once the tool has been secured, the stowage bay lock
must be rotated open before extracting the tool ... After the gripper is engaged, the RWE
behavior is used to finely adjust the attractor position and further eliminate forces."

    approach  PTWL 40 mm down at up to 10 N: the gripper's pad on the tool's knob
              -> no contact: failed
    grasp     close the gripper: it catches the knob, pulling it (and the arm) into the grasp,
              the paper's closing impact -> caught nothing: failed
    relieve   RWE: the impact's wrench goes
    unlock    PTWL 0.8 rad about the tool axis (at up to 2 N m): the legs turn out from under
              the bay's tabs against the lock's spring -> turned less than 0.6 rad: failed
    extract   PTWL 60 mm up -> the goal reached: completed; stopped (still caught): failed
"""

from robot_sim.behaviors import BehaviorReport, ExitCondition
from robot_sim.policies.base import Decision, Finish, StagedPolicy, Step
from robot_sim.policies.tool_bay import CLOSE, RELIEVE, TURN_OPEN_RAD, down, lock_turned, turn, up
from robot_sim.policies.travel import travel_down_tool_axis_m

APPROACH = down(0.04)
EXTRACT = up(0.06)


class ToolRetrieval(StagedPolicy):
    task = "tool_retrieval"
    summary = "down onto the tool; close the gripper; relieve; turn the lock open; lift it out"

    def opening(self) -> Step:
        return self.stage(
            "approach", APPROACH, "approach: PTWL 40 mm down at up to 10 N, onto the tool's knob"
        )

    def next(self, report: BehaviorReport) -> Decision:
        if self.last == "approach":
            depth = 1000 * travel_down_tool_axis_m(self.start, report.final_port)
            if report.exit is not ExitCondition.WRENCH_BREACH:
                return Finish(False, f"nothing under the gripper ({report.exit}, {depth:.1f} mm down)")
            return self.stage("grasp", CLOSE, f"on the knob ({depth:.1f} mm down): close the gripper")
        if self.last == "grasp":
            if not report.detail.startswith("holding"):
                return Finish(False, f"the gripper {report.detail}")
            return self.stage("relieve", RELIEVE, f"{report.detail}: relieve the closing impact")
        if self.last == "relieve":
            return self.stage(
                "unlock", turn(-TURN_OPEN_RAD), "turn the tool 0.8 rad: its legs out from under the tabs"
            )
        if self.last == "unlock":
            opened, turned = lock_turned(self.start, report)
            if not opened:
                return Finish(False, f"the lock turned only {turned} ({report.exit})")
            return self.stage("extract", EXTRACT, f"lock open ({turned}): lift the tool out")
        if report.exit is ExitCondition.GOAL_REACHED:
            return Finish(True, "the tool is out of the bay, in the gripper")
        return Finish(False, f"the tool would not come out ({report.exit} at {report.peak_force:.1f} N)")

"""The gripper's close and open (paper 2.3.3-2.3.4): the attractor holds still while the jaws
move; what closing catches is the scene's business (robot_sim/scenes/grasp.py), applied by the
simulation when the command starts. It ends `completed` after its duration; the report's
detail says what the jaws hold."""

from robot_sim import tick
from robot_sim.behaviors.base import Behavior
from robot_sim.controller import AdmittanceController
from robot_sim.params import GripperParams
from robot_sim.task_frames import TaskFrames


class Gripper(Behavior):
    kind = "gripper"

    def __init__(self, params: GripperParams) -> None:
        self.params = params

    def start(self, ctl: AdmittanceController, t: float, frames: TaskFrames) -> None:
        # the attractor stays where it is: a held force survives the grasp; `completed` at the end
        ctl.start_motion(tick.MOTION_GRIPPER, t, self.params.duration)

"""The three behaviors (and the gripper's close/open), and the one place that maps a validated
request to its behavior."""

from robot_sim.behaviors.base import Behavior, BehaviorReport, ExitCondition, Pose
from robot_sim.behaviors.dither import Dither
from robot_sim.behaviors.gripper import Gripper
from robot_sim.behaviors.ptwl import Ptwl
from robot_sim.behaviors.rwe import Rwe
from robot_sim.params import DitherParams, GripperParams, PtwlParams, RweParams

BehaviorParams = PtwlParams | RweParams | DitherParams | GripperParams


def behavior_for(params: BehaviorParams) -> Behavior:
    """A fresh behavior instance for validated parameters (dispatch on the `type` field)."""
    if isinstance(params, PtwlParams):
        return Ptwl(params)
    if isinstance(params, RweParams):
        return Rwe(params)
    if isinstance(params, GripperParams):
        return Gripper(params)
    return Dither(params)


__all__ = [
    "Behavior",
    "BehaviorParams",
    "BehaviorReport",
    "Dither",
    "ExitCondition",
    "Gripper",
    "Pose",
    "Ptwl",
    "Rwe",
    "behavior_for",
]

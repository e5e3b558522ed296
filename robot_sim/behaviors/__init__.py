"""The three behaviors, and the one place that maps a validated request to its behavior."""

from robot_sim.behaviors.base import Behavior, BehaviorReport, ExitCondition, Pose
from robot_sim.behaviors.dither import Dither
from robot_sim.behaviors.ptwl import Ptwl
from robot_sim.behaviors.rwe import Rwe
from robot_sim.params import DitherParams, PtwlParams, RweParams

BehaviorParams = PtwlParams | RweParams | DitherParams


def behavior_for(params: BehaviorParams) -> Behavior:
    """A fresh behavior instance for validated parameters (dispatch on the `type` field)."""
    if isinstance(params, PtwlParams):
        return Ptwl(params)
    if isinstance(params, RweParams):
        return Rwe(params)
    return Dither(params)


__all__ = [
    "Behavior",
    "BehaviorParams",
    "BehaviorReport",
    "Dither",
    "ExitCondition",
    "Pose",
    "Ptwl",
    "Rwe",
    "behavior_for",
]

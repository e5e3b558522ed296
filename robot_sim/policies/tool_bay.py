"""What the two tool machines share (paper 2.3.2-2.3.4): turning the bay's bayonet lock with the
held tool, and the moves in and out of the bay, all `medium` (a state machine must not inherit
whatever gains the last operator left)."""

import math

from robot_sim.behaviors import BehaviorReport, Pose
from robot_sim.params import GripperParams, PtwlParams, RweParams
from robot_sim.policies.travel import twist_about_tool_axis_rad

TURN_OPEN_RAD = 0.8  # the legs clear the tabs past 0.52 rad (30 deg)
OPENED_RAD = 0.6  # the port turned at least this: the lock is open
RELIEVE = RweParams(duration=1.0)
CLOSE = GripperParams(action="close")
OPEN = GripperParams(action="open")


def down(distance_m: float, force_n: float = 10.0) -> PtwlParams:
    """Along the tool axis (down the bay), to a contact at up to `force_n`."""
    return PtwlParams(
        translation=[0.0, 0.0, distance_m], duration=3.0, force_threshold=force_n, preset="medium"
    )


def up(distance_m: float) -> PtwlParams:
    return PtwlParams(
        translation=[0.0, 0.0, -distance_m], duration=4.0, force_threshold=15.0, preset="medium"
    )


def turn(about_tool_z_rad: float) -> PtwlParams:
    """About the tool axis, which points down: negative turns the bay's tool counter-clockwise
    seen from above, the way that opens the lock."""
    return PtwlParams(
        rotation=[0.0, 0.0, about_tool_z_rad], duration=2.0, torque_threshold=2.0, preset="medium"
    )


def turned_open_rad(home: Pose, report: BehaviorReport) -> float:
    """How far the port has turned the lock open (positive) since the start."""
    return -twist_about_tool_axis_rad(home, report.final_port)


def lock_turned(home: Pose, report: BehaviorReport) -> tuple[bool, str]:
    """(the lock is open, how far it turned in words), after an unlock turn."""
    turned = turned_open_rad(home, report)
    return turned >= OPENED_RAD, f"{math.degrees(turned):.0f} deg"

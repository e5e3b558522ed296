"""The words a report gives to what held its port back (robot_sim/held_back.py)."""

import numpy as np

from robot_sim.controller import Limit
from robot_sim.held_back import held_back_detail

RANGE_RAD = np.radians([[-170.0, 170.0]] * 4 + [[-120.0, 120.0], [-360.0, 360.0]])


def test_longest_first_and_only_the_joint_limit_names_its_joints() -> None:
    said = held_back_detail({Limit.SINGULARITY: 1.2, Limit.JOINT_LIMIT: 6.41}, {4: "upper"}, RANGE_RAD)
    assert said == "limited: joint_limit (6.41 s; joint 5 at its upper end, +120 deg), singularity (1.20 s)"


def test_joints_at_their_ends_are_not_said_of_another_limit_and_nothing_held_says_nothing() -> None:
    assert held_back_detail({Limit.SPEED: 0.5}, {0: "lower"}, RANGE_RAD) == "limited: speed (0.50 s)"
    assert held_back_detail({}, {0: "lower"}, RANGE_RAD) == ""

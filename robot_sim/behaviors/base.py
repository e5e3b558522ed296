"""What every behavior shares: exit conditions, the report, and the interface the runner drives.

A behavior only moves the attractor (and may set stiffness/damping at its start); the
admittance controller does the rest. It starts from the attractor where it is (re-placed only
so that new stiffness pulls as the old did: `AdmittanceController.change_gains`)
and ends with exactly one exit condition, after which the attractor stays where it was, except
after a wrench breach with `on_breach: limit`, where it is placed to hold the threshold.
"""

from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass
from enum import StrEnum

import numpy as np

from robot_sim import tick
from robot_sim.controller import AdmittanceController
from robot_sim.params import MonitorSpec, OnBreach
from robot_sim.pose_math import rotvec_from_to
from robot_sim.task_frames import TaskFrames


class ExitCondition(StrEnum):
    GOAL_REACHED = "goal_reached"
    WRENCH_BREACH = "wrench_breach"
    TIMEOUT = "timeout"
    COMPLETED = "completed"  # an RWE that relieved; a state machine that believes its task done
    FAILED = "failed"  # a state machine that gave up (its report's detail says why)
    ABORTED = "aborted"
    FAULT = "fault"
    ANOMALY = "anomaly"  # the force task monitor found the contact forces off its model
    EXPIRED = "expired"  # never started: its max_age or valid_until_sim_time had passed (params.py)


# A base-frame pose as (position [m], unit quaternion wxyz) arrays: the form numpy math and
# viser take (the console's markers and targets). `Pose` is the same pose as plain numbers.
PoseArrays = tuple[np.ndarray, np.ndarray]


@dataclass(frozen=True)
class Pose:
    """Base-frame pose: position [m] and unit quaternion [w x y z]."""

    position: tuple[float, float, float]
    quaternion: tuple[float, float, float, float]

    @staticmethod
    def of(position: Sequence[float] | np.ndarray, quaternion: Sequence[float] | np.ndarray) -> "Pose":
        """From any three and four numbers (lists from JSON, arrays): the one conversion."""
        x, y, z = (float(v) for v in position)
        w, qx, qy, qz = (float(v) for v in quaternion)
        return Pose((x, y, z), (w, qx, qy, qz))

    def as_dict(self) -> dict[str, list[float]]:
        return {"position": list(self.position), "quaternion": list(self.quaternion)}

    def arrays(self) -> PoseArrays:
        return np.array(self.position, dtype=float), np.array(self.quaternion, dtype=float)

    def displacement_to(self, goal: "Pose") -> tuple[list[float], list[float]]:
        """(translation [m], rotation vector [rad]), base axes, taking this pose to `goal`: a
        PTWL's move in `frame: base` from here."""
        (p, q), (p_goal, q_goal) = self.arrays(), goal.arrays()
        return (p_goal - p).tolist(), rotvec_from_to(q, q_goal).tolist()


@dataclass(frozen=True)
class BehaviorReport:
    """How a behavior ended, with the figures the paper's tables use."""

    behavior: str
    exit: ExitCondition
    started_at: float  # sim time [s]
    ended_at: float  # sim time [s]
    peak_force: float  # max |f| over the behavior [N]
    peak_torque: float  # max |tau| about the port [N m]
    final_wrench: tuple[float, ...]  # (6,) environment on port, base axes [N, N m]
    final_port: Pose
    detail: str = ""

    @property
    def duration(self) -> float:
        return self.ended_at - self.started_at


def end_breach(
    ctl: AdmittanceController, on_breach: OnBreach, force_threshold: float, torque_threshold: float
) -> ExitCondition:
    """What a breach does to the attractor; returns WRENCH_BREACH.

    `freeze` (the paper's literal rule): the attractor stays where it was, and the force it
    holds is whatever it had built up, about B v past the threshold at approach speed v.
    `limit` (default): the measured wrench is clipped to the thresholds and the attractor is
    placed to balance that (the bumpless rule), so the held force settles at the threshold.
    """
    if on_breach == "limit":
        w = ctl.w_world_env_on_port.copy()
        for block, threshold in ((slice(0, 3), force_threshold), (slice(3, 6), torque_threshold)):
            norm = float(np.linalg.norm(w[block]))
            if norm > threshold:
                w[block] *= threshold / norm
        ctl.balance(w)
    return ExitCondition.WRENCH_BREACH


# What the compiled loop's stop means, unless the behavior says otherwise (`exit_for`).
_EXITS: dict[int, ExitCondition] = {
    tick.Stop.GOAL_REACHED: ExitCondition.GOAL_REACHED,
    tick.Stop.WRENCH_BREACH: ExitCondition.WRENCH_BREACH,
    tick.Stop.TIMEOUT: ExitCondition.TIMEOUT,
    tick.Stop.COMPLETED: ExitCondition.COMPLETED,
}


class Behavior(ABC):
    """One compliant behavior. Its start sets up the attractor's motion in the controller's
    motion block; every control tick after that, the compiled loop (tick.py, `_move_attractor`)
    moves the attractor and checks the exits, and `exit_for` says what its stop means."""

    kind: str

    @abstractmethod
    def start(self, ctl: AdmittanceController, t: float, frames: TaskFrames) -> None:
        """Take the port and attractor poses at start and set up the attractor's motion
        (`ctl.start_motion` and the fields tick.py's motion block names)."""

    def exit_for(self, ctl: AdmittanceController, stop: int) -> ExitCondition:
        """The exit condition of the loop's `stop` (a tick.Stop code); acts on it first where the
        behavior must (a breach's `on_breach`)."""
        return _EXITS[stop]

    def monitor_spec(self) -> MonitorSpec | None:
        """The force task monitor it asked for (task_monitor.py), if any."""
        return None

    def goal_pose(self) -> Pose | None:
        """(after start) The absolute pose it drives the port to, if it has one: what an
        operator's display should show as commanded once the robot has resolved a relative
        displacement against the port where it really was at start."""
        return None

    def shortfall(self, ctl: AdmittanceController) -> str:
        """(at an end short of its goal) How far the port is from the goal, if it has one."""
        return ""

"""The ground twin's own simulation (web/twin.py): the console's copy of the robot model, the
commands queued in it (each no earlier than it can reach the robot), and the robot-clock
arithmetic that says when that is.

Not thread-safe: only the twin's thread runs it."""

import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from robot_sim.behaviors import BehaviorParams, behavior_for
from robot_sim.behaviors.base import Pose, PoseArrays
from robot_sim.errors import UnknownNameError
from robot_sim.gains import Gains
from robot_sim.geometry import body_poses, moving_bodies
from robot_sim.params import PtwlParams
from robot_sim.sim import UNBOUNDED_TICKS, Simulation
from robot_sim.task_frames import TaskFrames
from robot_sim.telemetry import gains_of
from web.twin_registration import CONTACT_N, FixtureRegistration


@dataclass
class Sent:
    """A command this console sent: `params` as validated, `sent_wall` its Unix send time (also
    its `sent_at` stamp), `pending` a view of whether the robot has yet to start it (the console's
    command history knows, once the robot's 202 has named it)."""

    params: BehaviorParams
    sent_wall: float
    pending: Callable[[], bool]


@dataclass(frozen=True)
class TwinPoint:
    """The twin's state now, to start another simulation from (a preview: web/preview.py)."""

    scene: str
    sim_time: float
    joint_positions: tuple[float, ...]
    attractor: Pose
    gains: Gains
    busy: bool  # a command still runs or waits in the twin
    frames: TaskFrames  # the robot's, as this console knows them


@dataclass(frozen=True)
class Prediction:
    sim_time: float
    port: PoseArrays
    bodies: dict[str, list[float]]


def robot_wall_s(state: dict[str, Any]) -> float:
    """[s] the robot's wall clock at the state's sim_time: `taken_at`, stamped on its simulation
    thread; else `sent_at` (a robot from before `taken_at`), which a busy event loop makes late."""
    return float(state.get("taken_at", state["sent_at"]))


def arrival_sim_s(t_state: float, taken_at: float, sent_wall: float, uplink_s: float) -> float:
    """[s] the robot's sim time when a command sent at `sent_wall` reaches it, by a state's
    (sim_time, taken_at) pair: the robot runs paced to its wall clock."""
    return t_state + (sent_wall + uplink_s - taken_at)


def point_from_state(state: dict[str, Any], frames: TaskFrames) -> TwinPoint:
    """A telemetry state as a start for a preview: where the robot was when it sent the state
    (the present on a short link, or when no twin runs)."""
    return TwinPoint(
        state["scene"],
        float(state["sim_time"]),
        tuple(state["joint_positions"]),
        _pose(state["attractor"]),
        gains_of(state["gains"]),
        state.get("active_command") is not None,
        frames,
    )


def point_from_sim(sim: Simulation, frames: TaskFrames, busy: bool) -> TwinPoint:
    """A simulation as it is now, as a start for a preview (the twin's, or a test's robot)."""
    state_now = sim.state()
    return TwinPoint(
        sim.scene.name,
        sim.time,
        state_now.joint_positions,
        state_now.attractor,
        sim.controller.gains,
        busy,
        frames,
    )


def _pose(message: dict[str, Any]) -> Pose:
    return Pose.of(message["position"], message["quaternion"])


STILL_M_S = 0.002  # [m/s] the robot's port slower than this (eq. 5 at its reported wrench): held
GIVE_WAY_S = 0.05  # [s] how long an idle twin is run to see whether its contact holds the press
GIVE_WAY_M = 0.0005  # [m] the port moving this far in that time: it does not


def _gives_way(sim: Simulation) -> bool:
    """Whether the twin, idle from where it was just put, moves GIVE_WAY_M within GIVE_WAY_S:
    what holds the robot still is not in the twin's model. Leaves the twin run on: the caller
    puts it back."""
    start = sim.controller.p_world_port.copy()
    end_s = sim.time + GIVE_WAY_S
    while sim.time < end_s:
        sim.step()
        if float(np.linalg.norm(sim.controller.p_world_port - start)) > GIVE_WAY_M:
            return True
    return False


def remaining_ptwl(message: dict[str, Any], port: Pose, elapsed_s: float) -> PtwlParams | None:
    """The rest of the robot's running PTWL as a PTWL from `port`: toward the goal the robot
    resolved, over the time its attractor still had to travel."""
    goal = message.get("goal")
    if message.get("behavior") != "ptwl" or goal is None:  # a command event names it `behavior`
        return None
    params = PtwlParams.model_validate(message["params"])
    assert params.watchdog is not None
    left_s = max(params.duration - elapsed_s, 1e-3)
    translation, rotation = port.displacement_to(_pose(goal))
    return params.model_copy(
        update={
            "translation": translation,
            "rotation": rotation,
            "frame": "base",
            "duration": left_s,
            "watchdog": max(params.watchdog - elapsed_s, left_s),
        }
    )


class TwinSim:
    def __init__(self, register: bool = True) -> None:
        self.sim: Simulation | None = None
        self._register = register  # the fixture from the robot's contacts (False: the nominal model)
        self.registration: FixtureRegistration | None = None
        self._moving: list[int] = []  # the bodies that move, as the ghost draws them
        self._queue: deque[tuple[BehaviorParams, float]] = deque()  # (params, not before [sim s])

    def load(self, scene: str) -> bool:
        """The twin runs `scene`'s model (made anew if it ran another); True if it was made."""
        if self.sim is not None and self.sim.scene.name == scene:
            return False
        self.sim = Simulation(scene)
        self._moving = moving_bodies(self.sim.model)
        applies = self._register and FixtureRegistration.applies_to(self.sim)
        self.registration = FixtureRegistration(self.sim) if applies else None
        return True

    def forget_registration(self) -> None:
        """The robot reloaded its scene (a new seed, a reset): what its contacts said of the old
        layout goes, and the twin's fixture back to its nominal place."""
        if self.registration is not None and self.sim is not None:
            self.registration.forget(self.sim)

    def restart(
        self,
        state: dict[str, Any],
        running: dict[str, Any] | None,
        sent: list[Sent],
        uplink_s: float,
        frames: TaskFrames,
    ) -> None:
        """From a telemetry state: the robot's running PTWL (its remaining part) first, then
        this console's commands the robot has not started, each at its arrival."""
        sim = self.sim
        assert sim is not None
        t_state, taken_at = float(state["sim_time"]), robot_wall_s(state)
        sim.frames = frames
        gains_now = gains_of(state["gains"])
        if gains_now.frame not in frames.names():  # a frame whose news is still on the link
            gains_now = gains_now.in_frame("base")
        attractor = _pose(state["attractor"])
        sim.sync_to(t_state, state["joint_positions"], attractor, gains_now)
        wrench = np.asarray(state["wrench"], dtype=float)
        force_n = float(np.linalg.norm(wrench[0:3]))
        if self.registration is not None:  # before it runs on: never from inside its own fixture
            self.registration.observe(sim, force_n)
        robot_speed = float(np.linalg.norm(sim.controller.twist_for(wrench)[0:3]))
        held = False
        if force_n >= CONTACT_N and robot_speed < STILL_M_S:
            held = _gives_way(sim)
            # The probe ran the twin on (and a fault in it would have reloaded the model):
            # back to the reported state, the fixture where the registration put it.
            sim.sync_to(t_state, state["joint_positions"], attractor, gains_now)
            if self.registration is not None:
                self.registration.ensure_placed(sim)
        if held:
            # The robot is held still by a contact the twin's model cannot bear (its fixture not
            # quite where the robot's is: a sleeve beside the peg slid on in the twin where the
            # robot's stayed jammed, 26 mm off): the twin holds there too, pressing on nothing,
            # and leaves the robot's stalled move out, rather than run to an attractor set
            # against a force it does not feel.
            sim.controller.balance(np.zeros(6))
        self._queue.clear()
        if not held and running is not None and running.get("started_at") is not None:
            elapsed_s = taken_at - float(running["started_at"])  # both the robot's wall clock
            port = sim.state().port  # after sync_to: the kinematics of the reported joints
            rest = remaining_ptwl(running, port, elapsed_s)
            if rest is not None:
                self._queue.append((rest, t_state))
        self.queue_at_arrival(sent, t_state, taken_at, uplink_s)

    def queue_at_arrival(self, sends: list[Sent], t_state: float, taken_at: float, uplink_s: float) -> None:
        """Each no earlier than it can reach the robot, by the (sim_time, taken_at) of a state."""
        for s in sends:
            self._queue.append((s.params, arrival_sim_s(t_state, taken_at, s.sent_wall, uplink_s)))

    def run_to(
        self,
        target_s: float,
        on_step: Callable[[float, np.ndarray], None],
        next_due_s: Callable[[], float] = lambda: -math.inf,
    ) -> None:
        """Step to `target_s`, starting each queued command at its time; `on_step(sim time,
        port position)` after the first step at or past `next_due_s()` [s] sim time (every step
        by default), and at the end."""
        sim = self.sim
        assert sim is not None
        queue = self._queue
        while sim.time < target_s:
            if sim.behavior is None and queue and sim.time >= queue[0][1]:
                self._start(sim, queue.popleft()[0])
            # Nothing starts while a behavior runs (its end stops the run), nor before the next
            # queued command's time.
            next_start_s = queue[0][1] if sim.behavior is None and queue else math.inf
            sim.advance(UNBOUNDED_TICKS, min(target_s, next_due_s(), next_start_s))
            on_step(sim.time, sim.controller.p_world_port)

    @staticmethod
    def _start(sim: Simulation, params: BehaviorParams) -> None:
        """Start a command in the twin; one naming a frame the console has not heard of yet
        (its news is still on the link) is left out: the twin holds, and its error readout shows."""
        try:
            sim.start(behavior_for(params))
        except UnknownNameError:
            sim.behavior = None

    def prediction(self) -> Prediction:
        sim = self.sim
        assert sim is not None
        port = (sim.controller.p_world_port.copy(), sim.controller.q_world_port.copy())
        return Prediction(sim.time, port, body_poses(sim.model, sim.data, self._moving))

    def point(self, frames: TaskFrames) -> TwinPoint:
        """Where the twin is now, to start a preview from."""
        sim = self.sim
        assert sim is not None
        return point_from_sim(sim, frames, busy=sim.behavior is not None or bool(self._queue))

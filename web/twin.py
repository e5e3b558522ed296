"""The ground twin behind the predictive display (issue 14; the teleoperation paper's commanded
and predicted displays): the console's own copy of the robot model, started from the latest
delayed telemetry and fed every command sent since, simulated forward to "now".

"Now" is the robot at the moment a command sent now would reach it: robot sim time
t(W) = t_state + (W - taken_at_state) (the robot runs paced to its wall clock), taken at
W = now + uplink. So the twin leads the delayed picture by a round trip, and a command starts
moving it as soon as it is sent; telemetry shows the same instant a round trip later, which is
when the twin's prediction for it is judged (`errors`).

Every `RESYNC_S` the twin restarts from the latest state (Simulation.sync_to), re-issues the
robot's running PTWL (its remaining part, toward the goal the robot resolved) and this console's
commands the robot has not started, each no earlier than it can arrive, one after another; in
between it runs on in real time. It knows the nominal scene only (no seeded misalignment), RWE,
Dither and state machines the robot is running are not replayed (the twin holds), and other
senders' commands are seen only once they run: the prediction error readout says how far to
trust it.
"""

import bisect
import threading
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from robot_sim.behaviors import BehaviorParams, behavior_for
from robot_sim.behaviors.base import Pose
from robot_sim.errors import UnknownNameError
from robot_sim.gains import Gains
from robot_sim.geometry import body_poses, moving_bodies
from robot_sim.params import PtwlParams
from robot_sim.pose_math import rotvec_from_to
from robot_sim.sim import Simulation
from robot_sim.task_frames import TaskFrames
from robot_sim.telemetry import gains_of

RESYNC_S = 0.5  # [s] wall time between restarts from the latest telemetry
RECORD_S = 0.01  # [s] sim time between recorded predictions
ERROR_WINDOW_S = 5.0  # [s] the readout's max is over this much wall time
MATCH_S = 0.015  # [s] a prediction judges a state within this much sim time of it


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
    port: tuple[np.ndarray, np.ndarray]  # position [m], wxyz
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


def _pose(message: dict[str, Any]) -> Pose:
    p, q = message["position"], message["quaternion"]
    return Pose((p[0], p[1], p[2]), (q[0], q[1], q[2], q[3]))


def remaining_ptwl(message: dict[str, Any], port: Pose, elapsed_s: float) -> PtwlParams | None:
    """The rest of the robot's running PTWL as a PTWL from `port`: toward the goal the robot
    resolved, over the time its attractor still had to travel."""
    goal = message.get("goal")
    if message.get("behavior") != "ptwl" or goal is None:  # a command event names it `behavior`
        return None
    params = PtwlParams.model_validate(message["params"])
    assert params.watchdog is not None
    left_s = max(params.duration - elapsed_s, 1e-3)
    p_goal, q_goal = np.asarray(goal["position"]), np.asarray(goal["quaternion"])
    translation = p_goal - np.asarray(port.position)
    rotation = rotvec_from_to(np.asarray(port.quaternion), q_goal)
    return params.model_copy(
        update={
            "translation": translation.tolist(),
            "rotation": rotation.tolist(),
            "frame": "base",
            "duration": left_s,
            "watchdog": max(params.watchdog - elapsed_s, left_s),
        }
    )


class GroundTwin:
    def __init__(self, uplink_s: Callable[[], float]) -> None:
        self._uplink_s = uplink_s
        self._lock = threading.Lock()
        self._state: dict[str, Any] | None = None  # the latest telemetry state
        self._running: dict[str, Any] | None = None  # the robot's running command's event
        self._sent: list[Sent] = []
        # The sent_at stamps of commands seen running or done: a `running` event can beat its
        # command's 202 across the link, and a command must not be replayed twice meanwhile.
        self._started_stamps: deque[float] = deque(maxlen=256)
        self._new_sends: list[Sent] = []
        self.sim: Simulation | None = None
        self._moving: list[int] = []
        self._queue: deque[tuple[BehaviorParams, float]] = deque()  # (params, not before [sim s])
        self._resynced_wall = -np.inf
        self._resync_due = False
        self._times: list[float] = []  # recorded predictions, sim time ascending
        self._ports: list[np.ndarray] = []
        self.latest: Prediction | None = None
        self.point: TwinPoint | None = None
        self.errors: deque[tuple[float, float]] = deque()  # (arrival wall, |error| [m])
        self.advanced_wall: float | None = None  # [s] the "now" of the last advance
        self.stop_sent_wall: float | None = None  # [s] a STOP sent, not confirmed yet
        # The robot's task frames as the console last heard (its scene's are where the seed put
        # the fixtures, which the twin's nominal scene does not know).
        self.frames = TaskFrames()

    # ----------------------------------------------------------- inputs (any thread)
    def on_state(self, state: dict[str, Any], arrived_wall: float) -> float | None:
        """A telemetry state arrived: the twin's next start, and a judge of what it predicted.
        Returns |predicted - reported| port position [m], if it had predicted that instant."""
        with self._lock:
            if self._state is not None and float(state["sim_time"]) < float(self._state["sim_time"]):
                # A scene (re)loaded: what was predicted for the old one goes, and so does its
                # judgment (it said nothing of the new one); the twin restarts from this state.
                self._times.clear()
                self._ports.clear()
                self.errors.clear()
                self._resync_due = True
            self._state = state
            error = self._error_for(state)
            if error is not None:
                self.errors.append((arrived_wall, error))
            while self.errors and self.errors[0][0] < arrived_wall - ERROR_WINDOW_S:
                self.errors.popleft()
            return error

    def on_command(self, message: dict[str, Any]) -> None:
        """A command event from the robot: which command runs (replayed at each restart)."""
        with self._lock:
            stamp = (message.get("params") or {}).get("sent_at")
            if stamp is not None and message.get("status") in ("running", "done"):
                self._started_stamps.append(float(stamp))
            if message.get("status") == "running":
                self._running = message
            elif self._running is not None and message.get("id") == self._running.get("id"):
                self._running = None

    def on_sent(self, sent: Sent) -> None:
        """This console sent a command: the twin starts it now (it is at the robot's "now" + uplink)."""
        with self._lock:
            self._sent.append(sent)
            self._new_sends.append(sent)

    def pause(self) -> None:
        """The worker stops advancing the twin (a short link): it restarts from telemetry when
        it goes on, and says nothing of the now meanwhile."""
        with self._lock:
            self._resync_due = True
            self.point = None

    def on_stop(self, sent_wall: float) -> None:
        """STOP sent: this console's commands will not run; until the robot confirms, the
        twin still replays the robot's running move (the ghost is unsure: web/twin_trust.py)."""
        with self._lock:
            self._sent.clear()
            self._new_sends.clear()
            self._resync_due = True
            self.stop_sent_wall = sent_wall

    def on_stop_confirmed(self, aborted: int | None) -> None:
        """The robot confirmed a STOP: the command it aborted is not replayed any more."""
        with self._lock:
            if self._running is not None and self._running.get("id") == aborted:
                self._running = None
            self.stop_sent_wall = None
            self._resync_due = True

    def judged_wall(self) -> float | None:
        """[s] when a prediction was last judged against the robot's state; None: not since the
        start or the last scene reset."""
        with self._lock:
            return self.errors[-1][0] if self.errors else None

    # ------------------------------------------------------------- the twin's thread
    def advance(self, now_wall: float) -> Prediction | None:
        """Run the twin to the robot's sim time at now + uplink; restart it from the latest state
        every RESYNC_S. Returns the prediction for now (None before any telemetry)."""
        with self._lock:
            state, running = self._state, self._running
            started = set(self._started_stamps)
            self._sent = [s for s in self._sent if s.pending() and s.sent_wall not in started]
            sent, new = list(self._sent), self._new_sends
            self._new_sends = []
            resync = self._resync_due or now_wall - self._resynced_wall >= RESYNC_S
            self._resync_due = False
        if state is None:
            return None
        uplink_s = self._uplink_s()
        t_state, taken_at = float(state["sim_time"]), robot_wall_s(state)
        target_s = arrival_sim_s(t_state, taken_at, now_wall, uplink_s)  # a command sent now
        if self.sim is None or self.sim.scene.name != state["scene"]:
            self.sim = Simulation(state["scene"])
            self._moving = moving_bodies(self.sim.model)
            resync = True
        if resync:
            self._restart(state, running, sent, uplink_s)
            self._resynced_wall = now_wall
        else:
            # At their arrival, not at the twin's time now: a starved twin thread stands behind
            # the send, and would start the command early by as long as it was held up.
            self._queue_at_arrival(new, t_state, taken_at, uplink_s)
        self._run_to(target_s, record=True)
        ctl = self.sim.controller
        port = (ctl.p_world_port.copy(), ctl.q_world_port.copy())
        self.latest = Prediction(self.sim.time, port, body_poses(self.sim.model, self.sim.data, self._moving))
        self.advanced_wall = now_wall
        state_now = self.sim.state()
        self.point = TwinPoint(
            self.sim.scene.name,
            self.sim.time,
            state_now.joint_positions,
            state_now.attractor,
            ctl.gains,
            self.sim.behavior is not None or bool(self._queue),
            self.frames,
        )
        return self.latest

    def _restart(
        self, state: dict[str, Any], running: dict[str, Any] | None, sent: list[Sent], uplink_s: float
    ) -> None:
        sim = self.sim
        assert sim is not None
        t_state, taken_at = float(state["sim_time"]), robot_wall_s(state)
        sim.frames = self.frames
        gains_now = gains_of(state["gains"])
        if gains_now.frame not in self.frames.names():  # a frame whose news is still on the link
            gains_now = gains_now.in_frame("base")
        sim.sync_to(t_state, state["joint_positions"], _pose(state["attractor"]), gains_now)
        self._queue.clear()
        if running is not None and running.get("started_at") is not None:
            elapsed_s = taken_at - float(running["started_at"])  # both the robot's wall clock
            port = sim.state().port  # after sync_to: the kinematics of the reported joints
            rest = remaining_ptwl(running, port, elapsed_s)
            if rest is not None:
                self._queue.append((rest, t_state))
        self._queue_at_arrival(sent, t_state, taken_at, uplink_s)

    def _queue_at_arrival(self, sends: list[Sent], t_state: float, taken_at: float, uplink_s: float) -> None:
        """Each no earlier than it can reach the robot, by the (sim_time, taken_at) of a state."""
        for s in sends:
            self._queue.append((s.params, arrival_sim_s(t_state, taken_at, s.sent_wall, uplink_s)))

    def _run_to(self, target_s: float, record: bool) -> None:
        sim = self.sim
        assert sim is not None
        while sim.time < target_s:
            if sim.behavior is None and self._queue and sim.time >= self._queue[0][1]:
                self._start(sim, self._queue.popleft()[0])
            sim.step()
            # What the ghost shows, every RECORD_S: a restart's replay up to there is not recorded.
            if record and (not self._times or sim.time >= self._times[-1] + RECORD_S):
                self._record(sim.time, sim.controller.p_world_port.copy())

    @staticmethod
    def _start(sim: Simulation, params: BehaviorParams) -> None:
        """Start a command in the twin; one naming a frame the console has not heard of yet
        (its news is still on the link) is left out: the twin holds, and its error readout shows."""
        try:
            sim.start(behavior_for(params))
        except UnknownNameError:
            sim.behavior = None

    def _record(self, sim_time: float, port: np.ndarray) -> None:
        with self._lock:
            self._times.append(sim_time)
            self._ports.append(port)
            if len(self._times) > 6000:  # a minute of predictions is plenty to judge by
                del self._times[:1000], self._ports[:1000]

    def _error_for(self, state: dict[str, Any]) -> float | None:
        """(under the lock) |predicted - reported| port position for the state's sim time."""
        t = float(state["sim_time"])
        i = bisect.bisect_left(self._times, t)
        best = min(
            (j for j in (i - 1, i) if 0 <= j < len(self._times)),
            key=lambda j: abs(self._times[j] - t),
            default=None,
        )
        if best is None or abs(self._times[best] - t) > MATCH_S:
            return None
        return float(np.linalg.norm(self._ports[best] - np.asarray(state["port"]["position"])))

    def error_summary(self) -> tuple[float, float] | None:
        """(last, max over the last ERROR_WINDOW_S) |prediction error| [m]; None before any."""
        with self._lock:
            if not self.errors:
                return None
            return self.errors[-1][1], max(e for _, e in self.errors)


def describe_error(summary: tuple[float, float] | None) -> str:
    """How far the twin's port predictions were off (last, 5 s max), in the operator's words."""
    if summary is None:
        return "not judged yet"
    last, worst = (1000.0 * e for e in summary)
    return f"off {last:.1f} mm (max {worst:.1f} over {ERROR_WINDOW_S:g} s)"

"""The ground twin judged on a virtual clock: a robot Simulation paced to a virtual wall clock
running its commands by the server's rule, a link that delays commands by the uplink and states
and events by the downlink, and the twin fed as the console feeds it. Deterministic and faster
than real time; the tests and bench.twin use it to measure the prediction error the console's
readout shows."""

import bisect
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np

from robot_sim.behaviors import BehaviorParams
from robot_sim.command_book import CommandBook, CommandRecord
from robot_sim.command_runner import CommandRunner
from robot_sim.limits import COMMAND_HISTORY_MAX, COMMAND_QUEUE_MAX
from robot_sim.params import PtwlParams
from robot_sim.sim import Simulation
from robot_sim.task_frames import TaskFrames
from robot_sim.telemetry import state_fields
from server.commands import command_message
from web.twin import RESYNC_S, GroundTwin, Sent
from web.twin_registration import CONTACT_N

STATE_S = 0.02  # telemetry at 50 Hz
TWIN_TICK_S = 0.02  # the console's twin thread runs every 20 ms
ACK_LAG_S = 0.1  # a command's 202 reaches the console this long after its `running` event
WALL0 = 1_800_000_000.0  # the virtual Unix time at sim time 0


@dataclass
class TrialResult:
    errors_m: list[float]  # |prediction - telemetry| for every state judged
    delayed_m: list[float] = field(default_factory=list)  # the same states vs the port a round trip earlier:
    # what the delayed picture showed when the twin made its prediction (the display without a twin)
    send_to_move_s: list[float] = field(
        default_factory=list
    )  # wall time from a send to the twin's port moving
    judged_sim_s: list[float] = field(default_factory=list)  # the sim time of each state in errors_m
    first_contact_sim_s: float | None = None  # the first state the robot sent touching (|f| >= CONTACT_N)
    rtt_s: float = 0.0

    @property
    def max_mm(self) -> float:
        return 1000.0 * max(self.errors_m)

    @property
    def p95_mm(self) -> float:
        return 1000.0 * float(np.percentile(self.errors_m, 95))

    @property
    def delayed_max_mm(self) -> float:
        return 1000.0 * max(self.delayed_m)

    @property
    def after_contact_max_mm(self) -> float | None:
        """Max error over the states predicted after the twin could know of the first contact:
        the console hears it a downlink after, the twin registers at its next restart, and its
        predictions lead by the uplink (sim time >= contact + rtt + RESYNC_S). None: no contact."""
        if self.first_contact_sim_s is None:
            return None
        since = self.first_contact_sim_s + self.rtt_s + RESYNC_S
        after = [e for e, t in zip(self.errors_m, self.judged_sim_s, strict=True) if t >= since]
        return 1000.0 * max(after) if after else None


def run_trial(
    robot: Simulation,
    rtt_s: float,
    sends: list[tuple[float, BehaviorParams]],
    seconds: float,
    twin_scene_check: Callable[[GroundTwin], None] | None = None,
    ack_lag_s: float = ACK_LAG_S,
    send_lag_s: float = 0.0,
    stamps_taken_at: bool = True,
    stall_s: float = 0.0,
    register: bool = True,
) -> TrialResult:
    """`sends`: (virtual seconds from the start, params), sent from the console; the link splits
    `rtt_s` evenly; `send_lag_s`: how long after it is taken each state leaves the robot (its
    event loop busy); `stamps_taken_at` False: a robot from before `taken_at`; `stall_s`: the
    twin's thread misses its ticks for this long before each send, waking just after it (the
    console's process starved of CPU); `register` False: the twin keeps its nominal fixture.
    Returns every prediction error the console would have shown."""
    trial = TwinTrial(robot, rtt_s, sends, ack_lag_s, send_lag_s, stamps_taken_at, stall_s, register)
    while trial.elapsed_s < seconds:
        trial.tick()
    if twin_scene_check is not None:
        twin_scene_check(trial.twin)
    return trial.result


class TwinTrial:
    """One control tick at a time: the console sends what is due, the link delivers, the robot
    runs its commands by the server's rule (robot_sim/command_book.py) and reports, the twin
    hears what the link lets down and predicts on its own 20 ms tick."""

    def __init__(
        self,
        robot: Simulation,
        rtt_s: float,
        sends: list[tuple[float, BehaviorParams]],
        ack_lag_s: float,
        send_lag_s: float,
        stamps_taken_at: bool,
        stall_s: float,
        register: bool = True,
    ) -> None:
        self.robot, self.rtt_s = robot, rtt_s
        self.up_s = self.down_s = rtt_s / 2.0
        self.ack_lag_s, self.send_lag_s, self.stamps_taken_at = ack_lag_s, send_lag_s, stamps_taken_at
        self.twin = GroundTwin(uplink_s=lambda: self.up_s, register=register)
        self.twin.frames = TaskFrames(robot.frames.all())  # as the console heard them (GET /api/frames)
        self.book = CommandBook(COMMAND_QUEUE_MAX, COMMAND_HISTORY_MAX, self._wall, self._changed)
        self.commands = CommandRunner(robot, self.book)
        self.to_robot: deque[tuple[float, BehaviorParams]] = deque()  # (arrival, params)
        self.to_console: deque[tuple[float, str, dict[str, Any]]] = deque()  # (arrival, kind, message)
        self.started: set[float] = set()  # sent_at stamps of commands whose `running` event came
        self.pending_sends = sorted(sends, key=lambda s: s[0])
        # Held up until just after the send: the thread wakes to a send it has not run to yet.
        self.stalls = [(at - stall_s, at + 0.005) for at, _ in self.pending_sends if stall_s > 0.0]
        self.result = TrialResult([], rtt_s=rtt_s)
        self.next_state = self.next_tick = 0.0
        self.moved_after: list[tuple[float, np.ndarray]] = []  # (send wall, twin port then)
        self.history: list[tuple[float, np.ndarray]] = []  # the robot's (sim time, port) as sent
        self.t0 = robot.time

    @property
    def elapsed_s(self) -> float:
        return self.robot.time - self.t0

    def _wall(self) -> float:
        return WALL0 + self.robot.time

    def tick(self) -> None:
        wall = self._wall()
        self._console_sends(wall)
        self._robot_receives(wall)
        self.commands.start_next()
        report = self.robot.step()
        if report is not None:
            self.commands.behavior_ended(report)  # its end event leaves through _changed
        self._robot_publishes_state(wall)
        self._console_receives(wall)
        self._twin_ticks(wall)

    def _console_sends(self, wall: float) -> None:
        while self.pending_sends and self.pending_sends[0][0] <= self.elapsed_s:
            _, unstamped = self.pending_sends.pop(0)
            params = unstamped.model_copy(update={"sent_at": wall})  # as the console stamps it
            self.to_robot.append((wall + self.up_s, params))
            # The console's history calls a command pending until it has both the robot's 202
            # and its `running` event; across the link the event usually comes first.
            acked_wall = wall + self.rtt_s + self.ack_lag_s
            self.twin.on_sent(Sent(params, wall, self._pending(wall, acked_wall)))
            if self.twin.latest is not None:
                self.moved_after.append((wall, self.twin.latest.port[0].copy()))

    def _pending(self, sent_wall: float, acked_wall: float) -> Callable[[], bool]:
        """The console's view: pending until its `running` event came and its 202 did."""
        return lambda: sent_wall not in self.started or self._wall() < acked_wall

    def _robot_receives(self, wall: float) -> None:
        while self.to_robot and self.to_robot[0][0] <= wall:
            self.book.submit(self.to_robot.popleft()[1])

    def _changed(self, record: CommandRecord) -> None:
        """The robot's command event (running, done) goes down the link."""
        if record.status in ("running", "done"):
            event = command_message(record)
            self.to_console.append((self._wall() + self.down_s, "command", event))

    def _robot_publishes_state(self, wall: float) -> None:
        robot = self.robot
        if self.elapsed_s < self.next_state:
            return
        self.next_state += STATE_S
        # As the robot sends it: taken now, leaving send_lag_s later.
        taken_at = WALL0 + robot.time
        state = {**state_fields(robot, []), "sent_at": taken_at + self.send_lag_s}
        touching = float(np.linalg.norm(state["wrench"][0:3])) >= CONTACT_N
        if touching and self.result.first_contact_sim_s is None:
            self.result.first_contact_sim_s = robot.time
        if self.stamps_taken_at:
            state["taken_at"] = taken_at
        self.to_console.append((wall + self.send_lag_s + self.down_s, "state", state))
        self.history.append((robot.time, robot.controller.p_world_port.copy()))

    def _console_receives(self, wall: float) -> None:
        while self.to_console and self.to_console[0][0] <= wall:
            arrival, kind, message = self.to_console.popleft()
            if kind == "command":
                if message.get("status") == "running":
                    self.started.add(float(message["params"]["sent_at"]))
                self.twin.on_command(message)
                continue
            error = self.twin.on_state(message, arrival)
            if error is not None:
                self.result.errors_m.append(error)
                self.result.judged_sim_s.append(float(message["sim_time"]))
                then = _port_at(self.history, float(message["sim_time"]) - self.rtt_s)
                shown = np.asarray(message["port"]["position"])
                self.result.delayed_m.append(float(np.linalg.norm(shown - then)))

    def _twin_ticks(self, wall: float) -> None:
        elapsed = self.elapsed_s
        if elapsed < self.next_tick or any(start <= elapsed < end for start, end in self.stalls):
            return
        while self.next_tick <= elapsed:  # after a stall, the next tick is 20 ms on
            self.next_tick += TWIN_TICK_S
        prediction = self.twin.advance(wall)
        if prediction is None:
            return
        for sent_wall, before in list(self.moved_after):
            if float(np.linalg.norm(prediction.port[0] - before)) > 1e-4:
                self.result.send_to_move_s.append(wall - sent_wall)
                self.moved_after.remove((sent_wall, before))


def _port_at(history: list[tuple[float, np.ndarray]], sim_time: float) -> np.ndarray:
    """The last port sent at or before `sim_time` (history is in time order)."""
    i = bisect.bisect_right(history, sim_time + 1e-9, key=lambda entry: entry[0])
    return history[max(i - 1, 0)][1]


def free_space_moves() -> list[tuple[float, BehaviorParams]]:
    """A run of PTWLs in free space, one sent while another runs (it queues); sent between the
    twin's restarts, so each must move it by itself."""
    return [
        (1.13, PtwlParams(translation=[0.0, 0.06, 0.0], frame="base", duration=2.0)),
        (2.07, PtwlParams(translation=[0.0, 0.0, 0.04], frame="base", duration=1.5)),
        (5.61, PtwlParams(translation=[0.03, -0.04, -0.02], frame="base", duration=2.5)),
    ]


def contact_moves() -> list[tuple[float, BehaviorParams]]:
    """Down onto the surface plate, a press, and a slide along it."""
    return [
        (1.0, PtwlParams(translation=[0.0, 0.0, -0.045], frame="base", duration=2.0, watchdog=3.0)),
        (4.5, PtwlParams(translation=[0.0, 0.04, -0.002], frame="base", duration=2.5, force_threshold=40.0)),
    ]


def contact_moves_and_back() -> list[tuple[float, BehaviorParams]]:
    """`contact_moves`, then a slide back along the plate at 9 s: something to predict after a
    5 s round trip has brought the first contact down."""
    back = PtwlParams(translation=[0.0, -0.04, 0.0], frame="base", duration=2.5, force_threshold=40.0)
    return [*contact_moves(), (9.0, back)]


def robot_with_model_error(
    scene: str, seed: int | None, shift_m: tuple[float, float, float], tilt_deg: float = 0.0
) -> Simulation:
    """A robot whose fixture is not where any model says: the scene's seeded layout, then its
    fixture moved `shift_m` (base axes) and tilted `tilt_deg` about x. The twin, which knows the
    nominal scene, must find it from the contacts (web/twin_registration.py)."""
    robot = Simulation(scene, seed)
    assert robot.scene.fixture_body is not None, f"{scene} has no fixture to move"
    body = robot.model.body(robot.scene.fixture_body).id
    robot.model.body_pos[body] += np.asarray(shift_m)
    tilt, turned = np.zeros(4), np.zeros(4)
    mujoco.mju_axisAngle2Quat(tilt, np.array([1.0, 0.0, 0.0]), np.radians(tilt_deg))
    mujoco.mju_mulQuat(turned, tilt, robot.model.body_quat[body].copy())
    robot.model.body_quat[body] = turned
    mujoco.mj_forward(robot.model, robot.data)
    return robot

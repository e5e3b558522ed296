"""The ground twin judged on a virtual clock: a robot Simulation paced to a virtual wall clock, a
link that delays commands by the uplink and states and events by the downlink, and the twin fed
as the console feeds it. Deterministic and faster than real time; the tests and bench.twin use
it to measure the prediction error the console's readout shows."""

import bisect
import itertools
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from robot_sim.behaviors import BehaviorParams, behavior_for
from robot_sim.params import PtwlParams
from robot_sim.sim import Simulation
from robot_sim.task_frames import TaskFrames
from robot_sim.telemetry import state_fields
from web.twin import GroundTwin, Sent

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

    @property
    def max_mm(self) -> float:
        return 1000.0 * max(self.errors_m)

    @property
    def p95_mm(self) -> float:
        return 1000.0 * float(np.percentile(self.errors_m, 95))

    @property
    def delayed_max_mm(self) -> float:
        return 1000.0 * max(self.delayed_m)


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
) -> TrialResult:
    """`sends`: (virtual seconds from the start, params), sent from the console; the link splits
    `rtt_s` evenly; `send_lag_s`: how long after it is taken each state leaves the robot (its
    event loop busy); `stamps_taken_at` False: a robot from before `taken_at`; `stall_s`: the
    twin's thread misses its ticks for this long before each send, waking just after it (the
    console's process starved of CPU). Returns every prediction error the console would have shown."""
    up_s = down_s = rtt_s / 2.0
    twin = GroundTwin(uplink_s=lambda: up_s)
    twin.frames = TaskFrames(robot.frames.all())  # as the console heard them (GET /api/frames)
    to_robot: deque[tuple[float, int, BehaviorParams]] = deque()  # (arrival wall, id, params)
    to_console: deque[tuple[float, str, dict[str, Any]]] = deque()  # (arrival wall, kind, message)
    robot_queue: deque[tuple[int, BehaviorParams]] = deque()
    started: set[int] = set()  # ids whose `running` event reached the console
    running: int | None = None
    pending_sends = sorted(sends, key=lambda s: s[0])
    # Held up until just after the send: the thread wakes to a send it has not run to yet.
    stalls = [(at - stall_s, at + 0.005) for at, _ in pending_sends if stall_s > 0.0]
    ids = itertools.count(1000)
    result = TrialResult([])
    next_state = next_tick = 0.0
    moved_after: list[tuple[float, np.ndarray]] = []  # (send wall, twin port then)
    history: list[tuple[float, np.ndarray]] = []  # the robot's (sim time, port) as sent
    t0 = robot.time
    wall = WALL0 + t0
    clock = [wall]  # the virtual wall clock, as `pending` views read it
    while robot.time - t0 < seconds:
        wall = clock[0] = WALL0 + robot.time
        while pending_sends and pending_sends[0][0] <= robot.time - t0:
            _, unstamped = pending_sends.pop(0)
            params = unstamped.model_copy(update={"sent_at": wall})  # as the console stamps it
            cid = next(ids)
            to_robot.append((wall + up_s, cid, params))
            # The console's history calls a command pending until it has both the robot's 202
            # and its `running` event; across the link the event usually comes first.
            twin.on_sent(Sent(params, wall, _pending(clock, started, cid, wall + rtt_s + ack_lag_s)))
            before = twin.latest.port[0].copy() if twin.latest is not None else None
            if before is not None:
                moved_after.append((wall, before))
        while to_robot and to_robot[0][0] <= wall:
            _, cid, params = to_robot.popleft()
            robot_queue.append((cid, params))
        if robot.behavior is None and robot_queue:
            cid, params = robot_queue.popleft()
            robot.start(behavior_for(params))
            running = cid
            goal = robot.behavior.goal_pose() if robot.behavior is not None else None
            message: dict[str, Any] = {
                "type": "command",  # as the robot's telemetry socket sends a command event
                "id": cid,
                "behavior": params.type,
                "status": "running",
                "params": params.model_dump(),
                "started_at": wall,
                "goal": goal.as_dict() if goal is not None else None,
            }
            to_console.append((wall + down_s, "command", message))
        report = robot.step()
        if report is not None and running is not None:
            to_console.append((wall + down_s, "command", {"id": running, "status": "done"}))
            running = None
        if robot.time - t0 >= next_state:
            next_state += STATE_S
            # As the robot sends it: taken now, leaving send_lag_s later.
            taken_at = WALL0 + robot.time
            state = {**state_fields(robot, []), "sent_at": taken_at + send_lag_s}
            if stamps_taken_at:
                state["taken_at"] = taken_at
            to_console.append((wall + send_lag_s + down_s, "state", state))
            history.append((robot.time, robot.controller.p_world_port.copy()))
        while to_console and to_console[0][0] <= wall:
            arrival, kind, message = to_console.popleft()
            if kind == "state":
                error = twin.on_state(message, arrival)
                if error is not None:
                    result.errors_m.append(error)
                    then = _port_at(history, float(message["sim_time"]) - rtt_s)
                    result.delayed_m.append(
                        float(np.linalg.norm(np.asarray(message["port"]["position"]) - then))
                    )
            else:
                if message.get("status") == "running":
                    started.add(int(message["id"]))
                twin.on_command(message)
        stalled = any(start <= robot.time - t0 < end for start, end in stalls)
        if robot.time - t0 >= next_tick and not stalled:
            while next_tick <= robot.time - t0:  # after a stall, the next tick is 20 ms on
                next_tick += TWIN_TICK_S
            prediction = twin.advance(wall)
            if prediction is not None:
                for sent_wall, before in list(moved_after):
                    if float(np.linalg.norm(prediction.port[0] - before)) > 1e-4:
                        result.send_to_move_s.append(wall - sent_wall)
                        moved_after.remove((sent_wall, before))
    if twin_scene_check is not None:
        twin_scene_check(twin)
    return result


def _pending(clock: list[float], started: set[int], cid: int, acked_wall: float) -> Callable[[], bool]:
    return lambda: cid not in started or clock[0] < acked_wall


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

"""The simulation thread: one Simulation, paced to real time, running commands in order.

The physics never waits for HTTP: requests from the event loop reach this thread through an
inbox it drains between 2 ms batches, and answers go back through futures. Telemetry and
command events leave through `publish`, which must not block (the app hands them to the event
loop with call_soon_threadsafe).
"""

import json
import math
import queue
import threading
import time
from collections.abc import Callable
from concurrent.futures import Future
from dataclasses import dataclass
from typing import Any

from robot_sim.behaviors import BehaviorReport
from robot_sim.behaviors.base import Pose
from robot_sim.command_book import CommandRecord
from robot_sim.command_runner import CommandRunner
from robot_sim.geometry import moving_bodies, scene_geometry
from robot_sim.machines.command import DecisionRequest
from robot_sim.policies.run import StepRecord
from robot_sim.scenes import get_scene
from robot_sim.sim import Simulation
from robot_sim.task_frames import TaskFrame
from robot_sim.telemetry import frames_change_message, frames_message, state_fields
from server.commands import CommandBook, command_message
from server.pacing import RealTimePacer

# [s] sim time stepped between clock checks. A request (a command, a STOP) wakes the loop at once
# (`_wake`), so this bounds only how far sim time runs ahead of the wall clock, not how long a
# command waits to start. At 2 ms with no wake, an idle robot on the contact scene took 12.0 % of
# a core, its loop turning 1,000 times a second; at 10 ms, 6.8 %, with commands' latency p50 6.1
# ms against 6.8 ms (`python -m bench.server`: idle_with_sim, command_latency_ms).
BATCH_S = 0.01


@dataclass
class _Request:
    action: Callable[[], Any]
    reply: "Future[Any]"


class SimRunner:
    def __init__(
        self,
        scene: str,
        seed: int | None,
        telemetry_hz: float,
        book: CommandBook,
        publish: Callable[[str], object],
    ) -> None:
        get_scene(scene)  # fail early, listing the scenes
        self.sim = Simulation(scene, seed)
        self._moving = moving_bodies(self.sim.model)
        self.book = book
        with book.held() as held:  # each use below takes the lock again
            self._commands = CommandRunner(self.sim, held, self._step_ended)
        self._publish = publish
        self._period = 1.0 / telemetry_hz
        self._batch = min(BATCH_S, self._period)
        self._stop = threading.Event()
        self._wake = threading.Event()  # set by each request and by close(): the wait ends at once
        self._pacer = RealTimePacer(self.sim, batch_s=self._batch, sleep=self._sleep)
        self._inbox: queue.SimpleQueue[_Request] = queue.SimpleQueue()
        self._thread = threading.Thread(target=self._run, name="ptwl-sim", daemon=True)
        self._seq = 0
        self._next_telemetry = 0.0
        # Each `frames` message's number (whole or change); states carry the latest as
        # `frames_rev`, so a client sees a change it lost. `frames_text`: the whole list now, the
        # first message a telemetry client gets (set here before its change is published).
        self._frames_rev = 0
        self.frames_text = json.dumps(frames_message(self.sim.frames, self._frames_rev))
        self.latest_state: dict[str, Any] = self._state()
        self.last_fault: str | None = None
        # (simulation thread) A recorder's: each behavior a command ran, and each scene load's
        # geometry (start, reset, a fault's reload), before the first state of that load.
        self.on_step: Callable[[int, StepRecord], None] | None = None
        self.on_scene_loaded: Callable[[dict[str, Any]], None] | None = None

    # ----------------------------------------------------------------- lifecycle
    def start(self) -> None:
        self._scene_loaded()  # before the thread runs: this thread is still the only one
        self._thread.start()

    def close(self) -> None:
        self._stop.set()
        self._wake.set()
        self._thread.join(timeout=5.0)

    # ------------------------------------------------- requests from other threads
    def call(self, action: Callable[[], Any]) -> "Future[Any]":
        """Run `action` on the simulation thread between batches; its result via the future."""
        reply: Future[Any] = Future()
        self._inbox.put(_Request(action, reply))
        self._wake.set()
        return reply

    def _sleep(self, seconds: float) -> None:
        """(simulation thread) The pacer's wait for the wall clock, cut short by a request. Cleared
        before the loop reads the inbox, so a request put after this never waits a batch."""
        self._wake.wait(seconds)
        self._wake.clear()

    def stop_all(self) -> dict[str, Any]:
        """(simulation thread) Abort the running command, drop the queue, hold the robot."""
        with self.book.held():
            stopped = self._commands.stop_all()
        return {"aborted": stopped.aborted, "dropped": stopped.dropped}

    def decide(self, command_id: int, request: DecisionRequest) -> None:
        """(simulation thread) The operator's decision for a waiting machine."""
        with self.book.held():
            self._commands.decide(command_id, request)
        self.latest_state = self._state()

    def reset_scene(
        self, name: str, seed: int | None, gripper_close_s: float | None = None
    ) -> dict[str, Any]:
        """(simulation thread) Stop everything and load `name` fresh (its gripper closing with
        time constant `gripper_close_s` [s]; None: the scene's own)."""
        stopped = self.stop_all()
        self.sim.reset(name, seed, gripper_close_s=gripper_close_s)
        self._moving = moving_bodies(self.sim.model)
        self._scene_loaded()
        self.latest_state = self._state()
        return stopped

    # ------------------------------------------------------------- task frames
    def frames_listed(self) -> tuple[list[TaskFrame], int]:
        """(simulation thread) The loaded scene's task frames (its own first) and the `rev` of the
        `frames` message that announced them as they are (GET /api/frames)."""
        return self.sim.frames.all(), self._frames_rev

    def add_frame(self, name: str, pose: Pose | None) -> TaskFrame:
        """(simulation thread) An operator's frame at `pose`, or at the port's pose now (None)."""
        frame = self.sim.add_operator_frame(name, pose)
        self._publish_frames(added=[frame])
        return frame

    def remove_frame(self, name: str) -> TaskFrame:
        """(simulation thread) Delete an operator's frame no queued or running command names."""
        frame = self.sim.frames.remove(name, self.book.naming_frame(name))
        self._publish_frames(removed=[name])
        return frame

    def _publish_frames(self, added: list[TaskFrame] | None = None, removed: list[str] | None = None) -> None:
        """Every client hears of the frames on the telemetry socket: the whole list on a scene
        load (no arguments), else only what changed."""
        self._frames_rev += 1
        whole = json.dumps(frames_message(self.sim.frames, self._frames_rev))
        self.frames_text = whole
        if added is None and removed is None:
            self._publish(whole)
        else:
            self._publish(json.dumps(frames_change_message(self._frames_rev, added or (), removed or ())))

    def geometry(self) -> dict[str, Any]:
        """(simulation thread) The loaded scene's geoms and bodies (GET /api/geometry)."""
        sim = self.sim
        return {
            "scene": sim.scene.name,
            "gripper_close_s": sim.gripper_close_time_s(),
            **scene_geometry(sim.model, sim.data),
        }

    def real_time_lag(self) -> float:
        """[s] wall time minus sim time since the scene (re)started; ~0 when keeping up."""
        return self._pacer.lag_s()

    def inject_fault(self) -> None:
        """(simulation thread) Test hook: poison the physics so the next step faults."""
        self.sim.data.qvel[0] = math.nan

    # ------------------------------------------------------------------ the loop
    def _run(self) -> None:
        while not self._stop.is_set():
            self._serve_inbox()
            if self.sim.behavior is None:
                self._start_next()
            self._advance()
            if self.sim.time >= self._next_telemetry:
                self._publish_state()

    def _serve_inbox(self) -> None:
        while True:
            try:
                request = self._inbox.get_nowait()
            except queue.Empty:
                return
            try:
                request.reply.set_result(request.action())
            except Exception as err:  # handed to the caller, never kills the loop
                request.reply.set_exception(err)

    def _start_next(self) -> None:
        with self.book.held():
            self._commands.start_next()

    def _advance(self) -> None:
        faults_before = self.sim.fault_count
        self._pacer.advance(on_report=self._command_done)
        if self.sim.fault_count != faults_before:
            self.last_fault = self.sim.last_fault
            with self.book.held():
                self._commands.scene_reloaded()  # a machine waiting for a decision ends `fault`
            self._scene_loaded()  # the physics faulted: the scene reloaded at t = 0

    def _scene_loaded(self) -> None:
        """(simulation thread) A scene (re)loaded at sim time 0: pace and publish from there."""
        self._pacer.rebase()
        self._next_telemetry = 0.0
        self._publish_frames()
        if self.on_scene_loaded is not None:
            self.on_scene_loaded(self.geometry())

    def _command_done(self, report: BehaviorReport) -> None:
        """A behavior ended: the command's end, or a state machine's step (the book announces it)."""
        with self.book.held():
            self._commands.behavior_ended(report)

    def _step_ended(self, command_id: int, step: StepRecord) -> None:
        if self.on_step is not None:
            self.on_step(command_id, step)

    # ----------------------------------------------------------------- telemetry
    def _state(self) -> dict[str, Any]:
        running = self.book.running
        return {
            **state_fields(self.sim, self._moving),
            "active_command": running.id if running else None,
            "machine": self._commands.machine_view(),
            "instance": self.book.instance,
            "frames_rev": self._frames_rev,
        }

    def _publish_state(self) -> None:
        self.latest_state = state = self._state()
        self._seq += 1
        # taken_at: the wall clock at this sim_time, stamped here on the simulation thread. The
        # socket's sent_at is stamped as the message leaves, after the event loop's queue: under
        # load later by tens of ms, which a ground twin timing commands by it would mistake for
        # the robot being that much further along.
        self._publish(json.dumps({"type": "state", "seq": self._seq, **state, "taken_at": time.time()}))
        self._next_telemetry += self._period
        if self._next_telemetry < self.sim.time:  # fell behind (dropped backlog): no burst
            self._next_telemetry = self.sim.time + self._period


def command_event(record: CommandRecord) -> str:
    """The command event's text (command_message, as JSON)."""
    return json.dumps(command_message(record))

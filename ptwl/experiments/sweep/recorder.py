"""`ptwl sweep --record`: one trial's MCAP, in the same topics as a live session's.

Log times are the trial's simulated time in nanoseconds from its start. The robot's telemetry
is taken at the server's default rate (50 Hz of sim time); each command's life (queued when its
POST reached the robot, running, done) and each behavior it ran are recorded as the robot saw
them; both directions of the link record every message's delay or drop. Recording only
watches: a trial's row is the same with or without it (a test holds it to that).
"""

from pathlib import Path
from typing import Any

from latency.clock import SimulatedLink
from latency.record import McapRecorder
from ptwl.experiments.sweep.robot import Done, VirtualRobot
from ptwl.experiments.sweep.spec import TrialSpec
from ptwl.recording.writer import SessionRecorder, versions
from robot_sim.executor import CommandParams
from robot_sim.geometry import moving_bodies, scene_geometry
from robot_sim.telemetry import frames_message, state_fields

TELEMETRY_PERIOD_S = 0.02  # the server's default telemetry rate, 50 Hz
INSTANCE = "sweep"


def _ns(t_s: float) -> int:
    return round(t_s * 1e9)


class TrialRecorder:
    def __init__(self, path: Path, spec: TrialSpec, robot: VirtualRobot, link: SimulatedLink) -> None:
        metadata = {"source": "ptwl sweep", **{k: str(v) for k, v in spec.as_dict().items()}, **versions()}
        self.path = path
        self._out = SessionRecorder(path, metadata, overwrite=True)  # a trial re-run replaces its file
        self._robot = robot
        self._moving = moving_bodies(robot.sim.model)
        self._sender = f"{spec.operator} operator"
        self._ids: dict[str, int] = {}  # tag -> command id (1, 2, ... in the order they reached the robot)
        self._running: str | None = None
        self._params: dict[str, CommandParams] = {}
        self._queued_s: dict[str, float] = {}
        self._started_s: dict[str, float] = {}
        self._steps = 0
        self._next_state_s = 0.0
        self._seq = 0  # the state messages' sequence number, from 1, as the server's
        # Both directions of the link, on the trial's clock, into this file (closed by close()).
        link.link.recorder = McapRecorder(self._out, _ns)
        sim = robot.sim
        self._out.geometry({"scene": sim.scene.name, **scene_geometry(sim.model, sim.data)}, 0)
        self._out.frames(frames_message(sim.frames), 0)  # a trial's frames are the scene's

    def observe(self, done: Done | None) -> None:
        """After the robot's tick: record what changed (cheap when nothing did)."""
        robot, now = self._robot, self._robot.sim.time
        ns = _ns(now)
        if len(robot.submitted) != len(self._ids):
            for tag in robot.submitted:
                if tag not in self._ids:
                    self._ids[tag] = len(self._ids) + 1
                    self._params[tag] = robot.submitted[tag].params
                    self._queued_s[tag] = now
                    self._command(tag, "queued", ns)
        running = robot.running_tag
        if running is not None and running != self._running:
            self._command(running, "running", ns)
        self._running = running
        steps = robot.figures.steps
        owner = done.tag if done is not None else running  # whose behavior just ended
        while self._steps < len(steps):
            self._out.step(self._ids[owner] if owner else 0, steps[self._steps].as_dict(), ns)
            self._steps += 1
        if done is not None:
            self._command(done.tag, "done", ns, done)
        if now >= self._next_state_s:
            self._next_state_s += TELEMETRY_PERIOD_S
            self._seq += 1
            state = {
                "type": "state",
                "seq": self._seq,
                **state_fields(robot.sim, self._moving),
                "active_command": self._ids.get(running) if running else None,
                "instance": INSTANCE,
            }
            self._out.state(state, ns)

    def close(self) -> None:
        self._out.close()

    def _command(self, tag: str, status: str, ns: int, done: Done | None = None) -> None:
        params = self._params[tag]
        event: dict[str, Any] = {
            "type": "command",
            "id": self._ids[tag],
            "instance": INSTANCE,
            "behavior": params.type,
            "status": status,
            "exit": None,
            "params": params.model_dump(),
            "queued_at": self._queued_s[tag],  # a trial's times are its sim time [s]
            "sender": self._sender,
        }
        ran = status == "running" or (done is not None and done.outcome.report is not None)
        if ran:
            event["started_at"] = self._started_s.setdefault(tag, ns / 1e9)
        if done is not None:  # one that never ran (expired) has an end and no start, as the server's
            event.update(exit=done.outcome.exit, detail=done.outcome.detail, ended_at=ns / 1e9)
        if done is not None and done.outcome.report is not None:
            r = done.outcome.report
            event.update(
                ended_at=r.ended_at,
                duration=r.duration,
                peak_force=r.peak_force,
                peak_torque=r.peak_torque,
                final_wrench=list(r.final_wrench),
                final_port=r.final_port.as_dict(),
            )
        self._out.command(event, ns)

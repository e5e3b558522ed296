"""`ptwl sweep --record`: one trial's MCAP, in the same topics as a live session's.

Log times are the trial's simulated time in nanoseconds from its start, and a command's own
times are its sim seconds (the virtual robot's clock starts at 0). The robot's telemetry
is taken at the server's default rate (50 Hz of sim time); each command's life (queued when its
POST reached the robot, running, done) and each behavior it ran are recorded as the robot saw
them; both directions of the link record every message's delay or drop. Recording only
watches: a trial's row is the same with or without it (a test holds it to that).
"""

from pathlib import Path

from latency.clock import SimulatedLink
from latency.record import McapRecorder
from ptwl.experiments.sweep.robot import VirtualRobot
from ptwl.experiments.sweep.spec import TrialSpec
from ptwl.recording.writer import SessionRecorder, versions
from robot_sim.command_book import CommandRecord
from robot_sim.geometry import moving_bodies, scene_geometry
from robot_sim.policies.run import StepRecord
from robot_sim.telemetry import frames_message, state_fields
from server.commands import command_message

TELEMETRY_PERIOD_S = 0.02  # the server's default telemetry rate, 50 Hz


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
        self._next_state_s = 0.0
        self._seq = 0  # the state messages' sequence number, from 1, as the server's
        # Both directions of the link, on the trial's clock, into this file (closed by close()).
        link.link.recorder = McapRecorder(self._out, _ns)
        sim = robot.sim
        self._out.geometry({"scene": sim.scene.name, **scene_geometry(sim.model, sim.data)}, 0)
        self._out.frames(frames_message(sim.frames), 0)  # a trial's frames are the scene's
        robot.on_record, robot.on_step = self._command, self._step
        self.observe()  # the robot as the trial starts, before any command reaches it

    def observe(self) -> None:
        """After the robot's tick: its telemetry when due (commands and steps come by the hooks)."""
        robot, now = self._robot, self._robot.sim.time
        if now >= self._next_state_s:
            self._next_state_s += TELEMETRY_PERIOD_S
            self._seq += 1
            state = {
                "type": "state",
                "seq": self._seq,
                **state_fields(robot.sim, self._moving),
                "active_command": running.id if (running := robot.book.running) else None,
                "instance": robot.book.instance,  # as its command events'
            }
            self._out.state(state, _ns(now))

    def close(self) -> None:
        self._out.close()

    def _command(self, record: CommandRecord) -> None:
        """A command's status changed on the robot: its event, as the server sends it (the one
        rule, server.commands.command_message), logged at the robot's time. The record's sender
        is the operator's tag for the command (how the virtual robot knows it again); the
        recording names who sent it, as a live session's does."""
        event = {**command_message(record), "sender": self._sender}
        self._out.command(event, _ns(self._robot.sim.time))

    def _step(self, command_id: int, step: StepRecord) -> None:
        self._out.step(command_id, step.as_dict(), _ns(self._robot.sim.time))

"""`ptwl serve --record FILE.mcap`: the robot's session to MCAP, on a thread of its own.

The simulation thread and the event loop only stamp and enqueue (a clock read and a queue put:
recording must not disturb the robot); this thread decodes, converts and writes. It records
the telemetry stream as sent (its states and its task frames), every command event, every
behavior a command ran, and the scene's geometry whenever the runner says the scene (re)loaded:
on start, on reset, after a fault's reload (queued before the first state of that load, so the
file draws what it moves).
"""

import json
import queue
import threading
import time
from pathlib import Path
from typing import Any

from ptwl.recording.writer import SessionRecorder, versions
from robot_sim.policies.run import StepRecord
from robot_sim.telemetry import FramesMirror
from server.config import ServerConfig


def session_metadata(config: ServerConfig) -> dict[str, str]:
    """What the file says about where it came from (MCAP metadata `ptwl`)."""
    return {
        "source": "ptwl serve",
        "scene": config.scene,
        "seed": str(config.seed),
        "telemetry_hz": f"{config.telemetry_hz:g}",
        "started": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        **versions(),
    }


class RecordingThread:
    def __init__(self, path: Path, metadata: dict[str, str]) -> None:
        self._recorder = SessionRecorder(path, metadata)
        self._inbox: queue.SimpleQueue[tuple[str, Any, int] | None] = queue.SimpleQueue()
        self._thread = threading.Thread(target=self._run, name="ptwl-record", daemon=True)
        self.failures = 0  # messages that could not be recorded (the first is reported)
        # The telemetry's `frames` changes, assembled: the file keeps each whole list, as a replay
        # answers GET /api/frames and a 3D panel places frames from one message.
        self._frames = FramesMirror()

    # ------------------------------------------------ from any thread: stamp and go
    def state(self, text: str) -> None:
        self._inbox.put(("state", text, time.time_ns()))

    def command(self, text: str) -> None:
        self._inbox.put(("command", text, time.time_ns()))

    def geometry(self, geometry: dict[str, Any]) -> None:
        self._inbox.put(("geometry", geometry, time.time_ns()))

    def step(self, command_id: int, step: StepRecord) -> None:
        self._inbox.put(("step", (command_id, step), time.time_ns()))

    # ------------------------------------------------------------------ lifecycle
    def start(self) -> None:
        self._thread.start()

    def close(self) -> None:
        """Write what is queued, then finish the file."""
        self._inbox.put(None)
        self._thread.join(timeout=10.0)
        self._recorder.close()

    def _run(self) -> None:
        while (item := self._inbox.get()) is not None:
            try:
                self._record(*item)
            except Exception as err:  # one bad message must not end the recording
                self.failures += 1
                if self.failures == 1:
                    print(
                        f"ptwl serve: recording: {type(err).__name__}: {err} (recording goes on)", flush=True
                    )

    def _record(self, kind: str, payload: Any, ns: int) -> None:
        if kind == "state":
            message = json.loads(payload)
            if message["type"] == "state":
                self._recorder.state(message, ns)
            elif message["type"] == "frames":
                if self._frames.apply(message) != "changed":  # it hears every message, in order
                    raise ValueError(f"frames rev {message['rev']} does not follow {self._frames.rev}")
                self._recorder.frames(self._frames.message(), ns)
        elif kind == "command":
            self._recorder.command(json.loads(payload), ns)
        elif kind == "geometry":
            self._recorder.geometry(payload, ns)
        else:
            command_id, step = payload
            self._recorder.step(command_id, step.as_dict(), ns)

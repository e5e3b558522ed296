"""The robot's state as telemetry carries it: plain, strict-JSON data (GET /api/state, the
telemetry socket, recordings). One builder for the server and the virtual-time sweeps."""

import math
from collections.abc import Iterable
from typing import Any, Literal

from robot_sim.gains import Gains
from robot_sim.geometry import body_poses
from robot_sim.scenes import TaskProgress
from robot_sim.sim import Simulation
from robot_sim.task_frames import TaskFrame, TaskFrames, frame_dict


def state_fields(sim: Simulation, moving: list[int]) -> dict[str, Any]:
    """The simulation's part of a state message (`moving`: geometry.moving_bodies of its model)."""
    state = sim.state()
    return {
        "sim_time": state.sim_time,
        "port": state.port.as_dict(),
        "attractor": state.attractor.as_dict(),
        "wrench": list(state.wrench),
        "joint_positions": list(state.joint_positions),
        "scene": state.scene,
        "manipulability": state.manipulability,
        "faults": sim.fault_count,
        "limited": state.limited,
        "bodies": body_poses(sim.model, sim.data, moving),
        "task": task_fields(sim.task()),
        "gains": gains_fields(sim.controller.gains),
        "monitor": sim.monitor.fields() if sim.monitor is not None else None,
    }


def frames_message(frames: TaskFrames, rev: int = 0) -> dict[str, Any]:
    """The whole `frames` message: every task frame, as GET /api/frames lists them. Sent on each
    scene load and first to each telemetry client as it connects; recordings keep only these."""
    return {"type": "frames", "rev": rev, "frames": [frame_dict(f) for f in frames.all()]}


def frames_change_message(
    rev: int, added: Iterable[TaskFrame] = (), removed: Iterable[str] = ()
) -> dict[str, Any]:
    """A `frames` message with only what changed since `rev - 1`: an add or a delete costs the
    same few hundred bytes however many frames exist (a whole list per add made 2,000 frames a
    286 KB message per add, and starved the state telemetry behind it on the link)."""
    return {"type": "frames", "rev": rev, "added": [frame_dict(f) for f in added], "removed": list(removed)}


FramesNews = Literal["changed", "stale", "gap"]
# GET /api/frames answers with the `rev` of the `frames` message its list matches, so a client
# mending a lost change knows exactly which later changes still apply.
FRAMES_REV_HEADER = "x-ptwl-frames-rev"


class FramesMirror:
    """A client's copy of the robot's task frames, kept by its `frames` messages: the one rule
    for applying them (the console's feed, the recorder, tests).

    A message with `frames` is the whole list and replaces the copy (a replay's seek may go back
    in `rev`). One with `added`/`removed` applies on top of `rev - 1`: an older one is already in
    the copy ("stale"); a newer one means one was lost on the link ("gap": fetch the whole list,
    GET /api/frames, and `replace`). State messages carry `frames_rev`, so a lost change shows
    at the next state even when no other change follows. GET /api/frames gives its `rev` in the
    FRAMES_REV_HEADER header."""

    def __init__(self) -> None:
        self.rev: int | None = None  # None until the first whole list
        self._frames: dict[str, dict[str, Any]] = {}

    def apply(self, message: dict[str, Any]) -> FramesNews:
        rev = message.get("rev")
        if "frames" in message:
            self.replace(message["frames"], rev)
            return "changed"
        if self.rev is not None and rev is not None and rev <= self.rev:
            return "stale"
        if self.rev is None or rev != self.rev + 1:
            return "gap"
        for name in message["removed"]:
            self._frames.pop(name, None)
        for frame in message["added"]:
            self._frames[frame["name"]] = frame
        self.rev = rev
        return "changed"

    def replace(self, frames: Iterable[dict[str, Any]], rev: int | None) -> None:
        self._frames = {f["name"]: f for f in frames}
        self.rev = rev

    def frames(self) -> list[dict[str, Any]]:
        """As GET /api/frames lists them: the scene's own, then the operators' in the order added."""
        return list(self._frames.values())

    def message(self) -> dict[str, Any]:
        """The whole `frames` message this copy amounts to (what a recording keeps)."""
        return {"type": "frames", "rev": self.rev, "frames": self.frames()}


def gains_fields(gains: Gains) -> dict[str, Any]:
    return {"stiffness": gains.stiffness.tolist(), "damping": gains.damping.tolist(), "frame": gains.frame}


def gains_of(fields: dict[str, Any]) -> Gains:
    """The gains a state's `gains` fields say were in force (the inverse of gains_fields)."""
    return Gains.of(fields["stiffness"], fields["damping"], fields["frame"])


def task_fields(progress: TaskProgress) -> dict[str, Any]:
    """The task predicate for telemetry; a non-finite progress (a fault mid-evaluation) is null,
    so every message stays strict JSON."""
    task = dict(progress.__dict__)
    if not math.isfinite(task["progress"]):
        task["progress"] = None
    return task

"""A session's MCAP file, written by the Foxglove SDK (its MCAP writer, its well-known schemas).

Nothing lost: the file is finished properly on close; until then a chunk is closed and flushed
to disk before it would span 1 s of log time, so a process killed outright (kill -9) leaves a
file readable up to its last whole chunk (ptwl/recording/reader.py reads such a file).

Not thread-safe: one thread feeds a recorder (the server gives it its own; a sweep trial is one
thread already).
"""

import json
import math
from importlib import metadata
from pathlib import Path
from typing import Any

import foxglove
from foxglove import Channel, Context, Schema
from foxglove.channels import (
    EventChannel,
    FrameTransformsChannel,
    JointStatesChannel,
    LogChannel,
    PoseInFrameChannel,
    SceneUpdateChannel,
)
from foxglove.mcap import MCAPWriteOptions
from foxglove.messages import FrameTransforms

from ptwl.recording import topics, well_known
from ptwl.recording.topics import ATTRACTOR_FRAME, PORT_FRAME, TASK_FRAME_PREFIX, WORLD_BODY
from robot_sim.arm import JOINT_NAMES
from robot_sim.finite import finite_json

CHUNK_SPAN_NS = 1_000_000_000  # a chunk never spans this much log time: kill -9 loses less
PROFILE = "ptwl"


def versions() -> dict[str, str]:
    return {f"version.{name}": metadata.version(name) for name in ("ptwl-console", "mujoco", "foxglove-sdk")}


_WELL_KNOWN: dict[str, Any] = {
    "foxglove.FrameTransforms": FrameTransformsChannel,
    "foxglove.PoseInFrame": PoseInFrameChannel,
    "foxglove.JointStates": JointStatesChannel,
    "foxglove.SceneUpdate": SceneUpdateChannel,
    "foxglove.Log": LogChannel,
    "foxglove.Event": EventChannel,
}


class SessionRecorder:
    def __init__(self, path: Path, metadata: dict[str, str], overwrite: bool = False) -> None:
        self.path = path
        self._context = Context()
        options = MCAPWriteOptions(profile=PROFILE)
        self._writer = foxglove.open_mcap(
            path, allow_overwrite=overwrite, context=self._context, writer_options=options
        )
        self._writer.write_metadata("ptwl", metadata)
        self._channels: dict[str, Any] = {}  # by topic, made on first use: a file holds what it has
        self._chunk_start_ns: int | None = None
        self._started_ns: dict[int, int] = {}  # command id -> log time it started running
        self.closed = False

    # ------------------------------------------------------------------ messages
    def state(self, message: dict[str, Any], ns: int) -> None:
        """A telemetry `state` message (the dict the WebSocket carries)."""
        self._chunk(ns)
        port, attractor = message["port"], message["attractor"]
        moved = [
            well_known.transform(ns, body, pose[:3], pose[3:])
            for body, pose in message.get("bodies", {}).items()
        ]
        moved.append(well_known.transform(ns, PORT_FRAME, port["position"], port["quaternion"]))
        moved.append(
            well_known.transform(ns, ATTRACTOR_FRAME, attractor["position"], attractor["quaternion"])
        )
        self._on(topics.TF).log(FrameTransforms(transforms=moved), log_time=ns)
        self._on(topics.PORT).log(well_known.pose_in_base(ns, port), log_time=ns)
        self._on(topics.ATTRACTOR).log(well_known.pose_in_base(ns, attractor), log_time=ns)
        self._on(topics.JOINTS).log(
            well_known.joint_states(ns, JOINT_NAMES, message["joint_positions"]), log_time=ns
        )
        self._on(topics.SCENE).log(
            well_known.force_arrow(ns, port["position"], message["wrench"]), log_time=ns
        )
        sim_time = message["sim_time"]
        wrench = message["wrench"]
        self._write(topics.WRENCH, ns, _wrench_fields(sim_time, wrench))
        task = message.get("task")
        if task is not None:
            self._write(topics.TASK, ns, {"sim_time": sim_time, "scene": message.get("scene"), **task})
        self._write(topics.TELEMETRY, ns, message)

    def geometry(self, geometry: dict[str, Any], ns: int) -> None:
        """The scene as loaded (GET /api/geometry): drawn, and every body placed once."""
        self._chunk(ns)
        self._write(topics.GEOMETRY, ns, geometry)
        placed = [
            well_known.transform(ns, name, body["pose"][:3], body["pose"][3:])
            for name, body in geometry["bodies"].items()
            if name != WORLD_BODY  # MuJoCo's world is the base frame itself
        ]
        self._on(topics.TF).log(FrameTransforms(transforms=placed), log_time=ns)
        self._on(topics.SCENE).log(well_known.scene_entities(ns, geometry), log_time=ns)

    def frames(self, message: dict[str, Any], ns: int) -> None:
        """The robot's task frames as the telemetry `frames` message gives them: kept whole (a
        replay answers GET /api/frames from it) and placed in /tf under frame/<name>, so a 3D
        panel can show any of them."""
        self._chunk(ns)
        self._write(topics.FRAMES, ns, message)
        placed = [
            well_known.transform(
                ns, TASK_FRAME_PREFIX + frame["name"], frame["pose"]["position"], frame["pose"]["quaternion"]
            )
            for frame in message["frames"]
        ]
        if placed:
            self._on(topics.TF).log(FrameTransforms(transforms=placed), log_time=ns)

    def command(self, event: dict[str, Any], ns: int) -> None:
        """A command event (status change) as the API sends it, `behavior` naming its type."""
        self._chunk(ns)
        self._write(topics.COMMANDS, ns, event)
        command_id, status, exit_condition = event["id"], event["status"], event.get("exit")
        who = f" by {event['sender']}" if event.get("sender") else ""
        text = f"#{command_id} {event['behavior']} {status}{who}"
        if status == "queued":
            text += f": {json.dumps(event.get('params', {}), sort_keys=True)}"
        if status == "running":
            self._started_ns[command_id] = ns
        if status == "done":
            text += f": {exit_condition}" + _peaks(event)
            if event.get("detail"):
                text += f" ({event['detail']})"
            fields = {"command": str(command_id), "behavior": event["behavior"], "exit": str(exit_condition)}
            if event.get("sender"):
                fields["sender"] = event["sender"]
            self._on(topics.EVENTS).log(
                well_known.command_event(self._started_ns.pop(command_id, ns), ns, fields), log_time=ns
            )
        self._on(topics.LOG).log(
            well_known.log_line(ns, "commands", text, exit_condition if status == "done" else None),
            log_time=ns,
        )

    def step(self, command_id: int, step: dict[str, Any], ns: int) -> None:
        """A behavior a command ran ended (StepRecord.as_dict()): a state machine's step, or
        the command itself."""
        self._chunk(ns)
        self._write(topics.STEPS, ns, {"command": command_id, **step})
        text = f"#{command_id} step {step['index']} {step['behavior']}: {step['exit']}" + _peaks(step)
        if step.get("why"):
            text += f" (chosen: {step['why']})"
        self._on(topics.LOG).log(well_known.log_line(ns, "steps", text, step["exit"]), log_time=ns)

    def link(self, record: dict[str, Any], ns: int) -> None:
        """One message through the link (latency/record.py's fields)."""
        self._chunk(ns)
        self._write(topics.LINK, ns, record)

    # ----------------------------------------------------------------- the file
    def flush(self) -> None:
        self._writer.flush()
        self._chunk_start_ns = None

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            self._writer.close()

    def _chunk(self, ns: int) -> None:
        """Close the chunk before it would span CHUNK_SPAN_NS (log times may step back a little
        between threads' stamps: a chunk then only grows shorter)."""
        if self._chunk_start_ns is None:
            self._chunk_start_ns = ns
        elif ns - self._chunk_start_ns >= CHUNK_SPAN_NS:
            self._writer.flush()
            self._chunk_start_ns = ns

    def _on(self, topic: topics.Topic) -> Any:
        channel = self._channels.get(topic.name)
        if channel is None:
            make = _WELL_KNOWN.get(topic.schema)
            if make is not None:
                channel = make(topic.name, context=self._context)
            else:
                schema = Schema(
                    name=topic.schema, encoding="jsonschema", data=topics.json_schema_bytes(topic.schema)
                )
                channel = Channel(topic.name, schema=schema, message_encoding="json", context=self._context)
            self._channels[topic.name] = channel
        return channel

    def _write(self, topic: topics.Topic, ns: int, message: dict[str, Any]) -> None:
        try:
            text = json.dumps(message, allow_nan=False)
        except ValueError:  # a fault's NaN: strict JSON for every reader, as the API does
            text = json.dumps(finite_json(message), allow_nan=False)
        self._on(topic).log(text.encode(), log_time=ns)


def _wrench_fields(sim_time: float, wrench: list[float]) -> dict[str, Any]:
    fx, fy, fz, tx, ty, tz = wrench
    return {
        "sim_time": sim_time,
        "force": {"x": fx, "y": fy, "z": fz},
        "torque": {"x": tx, "y": ty, "z": tz},
        "force_norm": math.hypot(fx, fy, fz),
        "torque_norm": math.hypot(tx, ty, tz),
    }


def _peaks(report: dict[str, Any]) -> str:
    force, torque = report.get("peak_force"), report.get("peak_torque")
    if force is None or torque is None:
        return ""
    return f", peak {force:.1f} N / {torque:.2f} N m"

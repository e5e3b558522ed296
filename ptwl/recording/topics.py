"""Every topic a ptwl recording holds: its name, its schema and what it means, in one place.

Foxglove's well-known schemas (protobuf, from the Foxglove SDK) carry what Foxglove's 3D, plot
and log panels show without configuration. Our own messages are JSON with a JSON Schema named
`ptwl.*`: the API's own field names and SI units, so a recorded message reads like the live one.

The root frame is `base`: the robot base frame, which is also MuJoCo's world frame (the arm's
base sits at the origin). Log times are Unix nanoseconds for a live session and simulated
nanoseconds from the trial's start for a virtual-time sweep trial.
"""

import json
from dataclasses import dataclass
from typing import Any

BASE_FRAME = "base"
WORLD_BODY = "world"  # MuJoCo's world body: the base frame itself, drawn in it
PORT_FRAME = "port"
ATTRACTOR_FRAME = "attractor"
TASK_FRAME_PREFIX = "frame/"  # a task frame's id in /tf: frame/peg_axis (a body may share its name)


@dataclass(frozen=True)
class Topic:
    name: str
    schema: str  # schema name: foxglove.* (protobuf) or ptwl.* (JSON)
    meaning: str


TF = Topic("/tf", "foxglove.FrameTransforms", "base -> each moving body, the port and the attractor")
PORT = Topic("/port", "foxglove.PoseInFrame", "the port of interaction's pose in base")
ATTRACTOR = Topic("/attractor", "foxglove.PoseInFrame", "the virtual attractor's pose in base")
JOINTS = Topic("/joint_states", "foxglove.JointStates", "the arm's six joint positions [rad]")
SCENE = Topic(
    "/scene",
    "foxglove.SceneUpdate",
    "the scene's geoms (on start and every reset) and the measured-force arrow",
)
LOG = Topic("/log", "foxglove.Log", "one line per command change, exit and state-machine step")
EVENTS = Topic("/events", "foxglove.Event", "each finished command as a time range with its exit")
WRENCH = Topic("/wrench", "ptwl.Wrench", "the measured wrench, environment on the port, base axes [N, N m]")
TASK = Topic("/task", "ptwl.Task", "the scene's success predicate and progress")
COMMANDS = Topic(
    "/commands", "ptwl.Command", "every command event as the API sends it: parameters, sender, status, exit"
)
STEPS = Topic("/steps", "ptwl.Step", "every state-machine step as it ends: behavior, exit, figures")
TELEMETRY = Topic("/ptwl/telemetry", "ptwl.Telemetry", "the telemetry state message, whole (replay reads it)")
GEOMETRY = Topic("/ptwl/geometry", "ptwl.Geometry", "GET /api/geometry's answer on start and every reset")
FRAMES = Topic(
    "/ptwl/frames",
    "ptwl.Frames",
    "the robot's named task frames (the telemetry `frames` message) on every scene load and change",
)
LINK = Topic("/link/messages", "ptwl.LinkMessage", "the link's per-message record: delays and drops")

ALL = (
    TF,
    PORT,
    ATTRACTOR,
    JOINTS,
    SCENE,
    LOG,
    EVENTS,
    WRENCH,
    TASK,
    COMMANDS,
    STEPS,
    TELEMETRY,
    GEOMETRY,
    FRAMES,
    LINK,
)
ROBOT = tuple(t for t in ALL if t is not LINK)  # what a robot session records


def _object(description: str, properties: dict[str, Any], **extra: Any) -> dict[str, Any]:
    return {"type": "object", "description": description, "properties": properties, **extra}


_VEC3 = {"type": "object", "properties": {k: {"type": "number"} for k in "xyz"}}
_NUM = {"type": "number"}
_NUM_OR_NULL = {"type": ["number", "null"]}

JSON_SCHEMAS: dict[str, dict[str, Any]] = {
    "ptwl.Wrench": _object(
        "Measured wrench, environment on the port, base-frame axes",
        {
            "sim_time": {**_NUM, "description": "[s]"},
            "force": {**_VEC3, "description": "[N]"},
            "torque": {**_VEC3, "description": "[N m]"},
            "force_norm": {**_NUM, "description": "[N]"},
            "torque_norm": {**_NUM, "description": "[N m]"},
        },
    ),
    "ptwl.Task": _object(
        "The scene's success predicate (GET /api/task)",
        {
            "sim_time": _NUM,
            "scene": {"type": "string"},
            "success": {"type": "boolean"},
            "progress": {**_NUM_OR_NULL, "description": "in `units`"},
            "goal": _NUM,
            "units": {"type": "string"},
            "detail": {"type": "string"},
        },
    ),
    "ptwl.Command": _object(
        "A command event (WS /api/telemetry `command`): the command's status as it changed",
        {
            "id": {"type": "integer"},
            "behavior": {"type": "string"},
            "status": {"type": "string"},
            "exit": {"type": ["string", "null"]},
            "sender": {"type": ["string", "null"]},
            "params": {"type": "object"},
            "started_at": _NUM_OR_NULL,
            "ended_at": _NUM_OR_NULL,
            "peak_force": _NUM_OR_NULL,
            "peak_torque": _NUM_OR_NULL,
        },
    ),
    "ptwl.Step": _object(
        "One behavior a command ran (a state machine's step, or the command itself)",
        {
            "command": {"type": "integer"},
            "index": {"type": "integer"},
            "behavior": {"type": "string"},
            "label": {"type": "string"},
            "exit": {"type": "string"},
            "started_at": _NUM,
            "ended_at": _NUM,
            "peak_force": _NUM,
            "peak_torque": _NUM,
        },
    ),
    "ptwl.Telemetry": _object("The telemetry `state` message (GET /api/state plus seq)", {"sim_time": _NUM}),
    "ptwl.Geometry": _object(
        "The scene's geoms and bodies (GET /api/geometry)", {"scene": {"type": "string"}}
    ),
    "ptwl.Frames": _object(
        "The robot's task frames (GET /api/frames), as the telemetry `frames` message carries them",
        {
            "type": {"type": "string", "const": "frames"},
            "frames": {
                "type": "array",
                "items": _object(
                    "A named frame: pose in base [m, w x y z], whose it is",
                    {
                        "name": {"type": "string"},
                        "pose": {"type": "object"},
                        "source": {"type": "string"},
                        "defined_by": {"type": "string"},
                    },
                ),
            },
        },
    ),
    "ptwl.LinkMessage": _object(
        "One message through the link: when it arrived and left, its delay or why it was dropped",
        {
            "seq": {"type": "integer"},
            "direction": {"type": "string", "enum": ["uplink", "downlink"]},
            "kind": {"type": "string"},
            "size": {"type": "integer"},
            "arrival": {**_NUM, "description": "[s] link clock"},
            "release": {**_NUM_OR_NULL, "description": "[s] link clock; null if dropped"},
            "scheduled_release": {
                **_NUM_OR_NULL,
                "description": "[s] link clock: when its rule let it go (release minus this: how late)",
            },
            "configured_delay": {**_NUM_OR_NULL, "description": "[s] every wait but the FIFO's order"},
            "realized_delay": {**_NUM_OR_NULL, "description": "[s]"},
            "why": {
                "type": "object",
                "description": "[s] each part of its wait: blackout, queue (behind others on the wire), "
                "contact_gap, serialization (size / rate), delay (one-way + jitter), order (FIFO)",
                "additionalProperties": _NUM,
            },
            "drop_reason": {"type": ["string", "null"]},
        },
    ),
}


def json_schema_bytes(name: str) -> bytes:
    return json.dumps(JSON_SCHEMAS[name]).encode()


def command_event(status: dict[str, Any]) -> dict[str, Any]:
    """A command's status (as GET /api/commands lists it) as its event, live and recorded:
    `{"type": "command", ...}`. The command's own `type` (ptwl, rwe, dither) would collide with
    the message's, so it travels as `behavior`. The one place for this rule, with its inverse."""
    fields = {k: v for k, v in status.items() if k != "type"}
    return {"type": "command", **fields, "behavior": status["type"]}


def command_status(event: dict[str, Any]) -> dict[str, Any]:
    """A command event as GET /api/commands listed the command then (command_event's inverse)."""
    fields = {k: v for k, v in event.items() if k not in ("type", "behavior")}
    return {**fields, "type": event["behavior"]}

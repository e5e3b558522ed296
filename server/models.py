"""API request and response models: the contract in docs/architecture.md, SI units, base frame.

Behavior parameters are robot_sim.params' models themselves, so the API, the config loader and
the library validate the same way.
"""

import math
from typing import Annotated, Any, Literal

from pydantic import (
    AfterValidator,
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    JsonValue,
    ValidationInfo,
    field_validator,
)

from robot_sim.errors import UnknownNameError
from robot_sim.limits import GRIPPER_CLOSE_S, MAX_SEED
from robot_sim.params import (
    FrameName,
    GripperCloseTime,
)
from robot_sim.scenes import SCENES, get_scene
from robot_sim.scenes.grasp import PNEUMATIC_CLOSE_S, GripperCloseError, check_close_time, takes_close_time
from robot_sim.task_frames import MAX_OPERATOR_FRAMES, unit_quaternion

CommandState = Literal["queued", "running", "done"]


def _integral(value: Any) -> Any:
    """JSON Schema counts 7.0 as an integer; strict pydantic would not. Strings and bools stay wrong."""
    if isinstance(value, float) and value.is_integer():
        return int(value)
    return value


def _known_scene(name: str) -> str:
    try:
        get_scene(name)
    except UnknownNameError as err:  # a KeyError: pydantic reports ValueErrors
        raise ValueError(str(err)) from None
    return name


SceneName = Annotated[str, AfterValidator(_known_scene), Field(json_schema_extra={"enum": list(SCENES)})]


class PoseModel(BaseModel):
    position: list[float] = Field(description="[m] x y z, base frame")
    quaternion: list[float] = Field(description="unit quaternion w x y z, base frame")


SENDER_HEADER = "x-ptwl-sender"
# Who sent a command is shown to every operator: letters, digits, space and . _ - : @ / # ( ) + ,
# only, so no markup character (< > & " ' `) can reach a page even before the console escapes it.
# With letters and digits: no markup character (< > & " ' `); '-' last, so literal in the class.
SENDER_SYMBOLS = " ._:@/#()+,-"
SENDER_MAX_CHARS = 64
SENDER_PATTERN = rf"^[A-Za-z0-9{SENDER_SYMBOLS}]{{1,{SENDER_MAX_CHARS}}}$"
SENDER_DOC = (
    f"who sends it (1-{SENDER_MAX_CHARS} of letters, digits, space and {' '.join(SENDER_SYMBOLS.strip())}), "
    "kept in its record"
)
INSTANCE_DOC = "the server run that gave the id (changes on every restart)"


class CommandAccepted(BaseModel):
    id: int = Field(description="command id, for GET /api/commands/{id}; never reused, across restarts too")
    instance: str = Field(description=INSTANCE_DOC)
    status: Literal["queued"] = Field("queued", description="always `queued`")
    warnings: list[str] = Field(
        default_factory=list,
        description="accepted, but worth knowing: e.g. an approach fast enough to pass the force "
        "threshold on impact (robot_sim/impact.py)",
    )


class CommandStatus(BaseModel):
    """One command's life; report fields are filled when it is done."""

    id: int = Field(description="command id; never reused, across restarts too")
    instance: str = Field(description=INSTANCE_DOC)
    type: Literal["ptwl", "rwe", "dither", "gripper", "state_machine"] = Field(
        description="the behavior, the gripper, or a task's state machine"
    )
    status: CommandState = Field(description="queued, running or done")
    exit: str | None = Field(
        None,
        description="goal_reached | wrench_breach | timeout | aborted | fault; an RWE or the gripper: "
        "completed | timeout | aborted | fault; a state machine: completed | failed | aborted | fault; "
        "a behavior with `monitor`: anomaly; any command: expired (its max_age or "
        "valid_until_sim_time passed before it could start)",
    )
    params: dict[str, Any] = Field(description="the validated parameters, defaults filled in")
    queued_at: float = Field(description="[s] server wall clock, Unix time")
    started_at: float | None = Field(None, description="[s] Unix time")
    ended_at: float | None = Field(None, description="[s] Unix time")
    duration: float | None = Field(None, description="[s] sim time from start to exit")
    peak_force: float | None = Field(None, description="[N] max |f| on the port while running")
    peak_torque: float | None = Field(None, description="[N m] max |tau| about the port while running")
    final_wrench: list[float] | None = Field(
        None, description="[N, N m] environment on port at exit; null if not finite (a fault)"
    )
    final_port: PoseModel | None = Field(None, description="port pose at exit; null if not finite")
    detail: str = Field(
        "",
        description="why it ended, when there is more to say: stop, fault, what the gripper holds; "
        "short of its goal, how far and every limit that held the port back, longest first "
        "(`port 245.7 mm and 20.5 deg from its goal; limited: singularity (7.44 s), joint_limit "
        "(7.20 s; joint 5 at its upper end, +120 deg)`; also speed)",
    )
    sender: str | None = Field(
        None, description=f"who sent it, from the `{SENDER_HEADER}` request header; null if not said"
    )
    machine: dict[str, Any] | None = Field(
        None,
        description="a state machine's: its state, visits, pending decision (`pending`: what it "
        "proposes, at what autonomy level, the report that led to it, the next behavior's parameters), "
        "decisions waited for and how long, its last decisions",
    )
    goal: PoseModel | None = Field(
        None,
        description="the absolute pose the robot resolved at start (a PTWL's port at start (+) its "
        "displacement); null before it starts and for behaviors without one",
    )
    steps: list["MachineStepModel"] = Field(
        default_factory=list,
        description="a state machine's behaviors so far, each with why it was chosen and how it ended",
    )


class MachineStepModel(BaseModel):
    index: int = Field(description="0, 1, ... in the order run")
    behavior: Literal["ptwl", "rwe", "dither", "gripper"] = Field(
        description="which behavior (or the gripper)"
    )
    params: dict[str, Any] = Field(description="its parameters, defaults filled in")
    why: str = Field(description="why the state machine chose it, from the previous step's report")
    state: str = Field("", description="its state's name, in a machine written as data (else empty)")
    exit: str = Field(description="how it ended")
    started_at: float = Field(description="[s] sim time")
    ended_at: float = Field(description="[s] sim time")
    peak_force: float | None = Field(description="[N] max |f| while it ran; null if not finite")
    peak_torque: float | None = Field(description="[N m] max |tau| while it ran; null if not finite")
    final_wrench: list[float] | None = Field(description="[N, N m] environment on port at its exit")
    final_port: PoseModel | None = Field(description="port pose at its exit; null if not finite")
    detail: str = Field(description="more on how it ended (what the gripper holds), or empty")


class TaskProgressModel(BaseModel):
    predicate: str = Field(description="what success means, in words")
    success: bool = Field(description="the predicate holds now")
    progress: float | None = Field(description="the measured quantity, in `unit`; null if not finite")
    target: float = Field(description="the value `progress` must reach, in `unit`")
    unit: str = Field(description="unit of `progress` and `target`")
    at_most: bool = Field(
        False, description="true: success wants `progress` at or below `target` (an error to shrink)"
    )


class ActiveGainsModel(BaseModel):
    stiffness: list[float] = Field(description="[N/m x3, N m/rad x3] diagonal K")
    damping: list[float] = Field(description="[N s/m x3, N m s/rad x3] diagonal B")
    # Any frame name a command's `gains_frame` may give (was base/tool only: GET /api/state
    # answered 500 after a PTWL with gains_frame "plate_normal"). A scene reset falls back to
    # base axes when the new scene has no frame of that name (robot_sim/sim.py), so the name is
    # always one GET /api/frames lists or a built-in.
    frame: FrameName = Field(description="the axes of the diagonal: `base`, `tool` or a task frame's name")


class MonitorModel(BaseModel):
    """The force task monitor of the running (or last) behavior that asked for one."""

    model: Literal["friction"] = Field(description="friction: tangential = mu |normal| + c while sliding")
    mu: float = Field(description="estimated friction coefficient")
    c: float = Field(description="[N] estimated constant tangential force")
    normal_force: float | None = Field(description="[N] |F_n| of the last 10 ms sample")
    tangential_force: float | None = Field(description="[N] |F_t| of the last sample")
    predicted: float = Field(description="[N] the model's F_t for it, made before seeing it")
    residual: float | None = Field(description="[N] measured - predicted")
    band: float = Field(description="[N] beyond this residual the sample is off the model")
    judging: bool = Field(description="sliding in contact past the warm-up: samples are judged")
    not_judging: str | None = Field(
        None,
        description="why it cannot judge now: `normal force X N < Y N` (out of contact, or so light a "
        "press that even a doubling of friction stays inside the band's floor); null otherwise",
    )
    anomaly: bool = Field(description="the behavior ended `anomaly`")
    samples_learned: int = Field(description="samples the estimator has learned from")


class RobotStateModel(BaseModel):
    sim_time: float = Field(description="[s] simulation time since the scene was loaded")
    port: PoseModel = Field(description="port of interaction (tool frame), base frame")
    attractor: PoseModel = Field(description="virtual attractor, base frame")
    wrench: list[float] = Field(description="[N, N m] environment on the port, base axes, about the port")
    joint_positions: list[float] = Field(description="[rad] joints 1-6")
    active_command: int | None = Field(description="id of the running command, or null")
    scene: str = Field(description="loaded scene")
    instance: str = Field(description=INSTANCE_DOC)
    manipulability: float = Field(description="sqrt(det(J J^T)); the DLS damps below 0.012")
    faults: int = Field(description="simulation faults since start (each reset the scene)")
    limited: str | None = Field(
        None,
        description="what holds the motion back now: singularity, joint_limit or speed (the first, "
        "when several do: a command's detail names them all); null if none",
    )
    bodies: dict[str, list[float]] = Field(
        default_factory=dict, description="moving bodies' poses [x y z (m), qw qx qy qz], base frame"
    )
    gains: ActiveGainsModel | None = Field(
        None, description="the stiffness and damping in force now (the running command's, or the last)"
    )
    task: TaskProgressModel | None = Field(
        None, description="the scene's success predicate now (as GET /api/task, without `scene`)"
    )
    monitor: MonitorModel | None = Field(
        None, description="the force task monitor, while a behavior with `monitor` runs and after it"
    )


class HealthModel(BaseModel):
    status: Literal["ok"] = Field(description="the server answers; see `faults` for the simulation")
    sim_time: float = Field(description="[s] simulation time since the scene was loaded")
    faults: int = Field(description="simulation faults since start; each ended its command `fault`")
    last_fault: str | None = Field(description="what the last fault was, or null")
    real_time_lag: float = Field(description="[s] wall time minus sim time; ~0 when keeping up")
    queued: int = Field(description="commands waiting to run")
    instance: str = Field(description=INSTANCE_DOC)
    long_polls: int = Field(description="GET /api/commands/{id}?wait= requests open now")


_GRIPPER_SCENES: list[JsonValue] = [name for name, scene in SCENES.items() if takes_close_time(scene.gripper)]


class SceneRequest(BaseModel):
    # The schema says which scenes take a gripper_close_s (the validator below is the rule):
    # a scene with a gripper, or none given.
    model_config = ConfigDict(
        extra="forbid",
        strict=True,
        json_schema_extra={
            "anyOf": [
                {"properties": {"name": {"enum": _GRIPPER_SCENES}}},
                {"properties": {"gripper_close_s": {"type": "null"}}},
            ]
        },
    )

    name: SceneName = Field(description="a scene from GET /api/scenes")
    # Field before the validator: the other way round the schema says "ge"/"le", which JSON
    # Schema does not know, instead of minimum/maximum (schemathesis sent -226 as valid).
    seed: Annotated[int, Field(ge=0, le=MAX_SEED), BeforeValidator(_integral)] | None = Field(
        None, description=f"[0, {MAX_SEED}] jitters the fixture; null for the nominal layout"
    )
    gripper_close_s: GripperCloseTime | None = Field(
        None,
        description=(
            f"[s] the gripper's closing time constant, [{GRIPPER_CLOSE_S[0]}, {GRIPPER_CLOSE_S[1]}], on a "
            f"scene whose gripper closes on a part (the tool bay's); null for the scene's own (0.01, "
            f"gentle). {PNEUMATIC_CLOSE_S}: "
            "the paper's pneumatic gripper, whose closing impact peaks near its 52 N"
        ),
    )

    @field_validator("gripper_close_s")
    @classmethod
    def _has_a_gripper(cls, close_s: float | None, info: ValidationInfo) -> float | None:
        if "name" in info.data:  # a bad name is reported on its own
            try:
                check_close_time(info.data["name"], get_scene(info.data["name"]).gripper, close_s)
            except GripperCloseError as err:  # the 422 names the field itself: not twice
                raise ValueError(str(err).removeprefix("gripper_close_s: ")) from None
        return close_s


class SceneModel(BaseModel):
    name: str = Field(description="scene name for POST /api/scene")
    description: str = Field(description="what is in it")


class TaskInfoModel(BaseModel):
    name: str = Field(
        description="task name for a `state_machine` command; it runs on the scene of that name"
    )
    summary: str = Field(description="its state machine's procedure in a line")
    settings: dict[str, Any] = Field(
        description="what a state_machine command's `overrides` may set: JSON schema per setting "
        "(type, default, range, description)"
    )
    machine: dict[str, Any] | None = Field(
        None,
        description="the machine as data (README: Machines), its transitions' autonomy levels with it; "
        "null: a Python machine, which runs at autonomy `full` only",
    )


class GeomModel(BaseModel):
    name: str = Field(description="geom name (may be empty)")
    body: str = Field(description="the body it is fixed to")
    type: Literal["plane", "sphere", "capsule", "cylinder", "box", "mesh"] = Field(
        description="MuJoCo geom type"
    )
    size: list[float] = Field(
        description="[m] MuJoCo sizes: half-extents (box), radius and half-length (capsule, cylinder)"
    )
    pos: list[float] = Field(description="[m] position in the body frame")
    quat: list[float] = Field(description="orientation in the body frame, w x y z")
    rgba: list[float] = Field(description="colour, 0-1")
    vertices: list[list[float]] | None = Field(None, description="[m] mesh vertices in the geom frame")
    faces: list[list[int]] | None = Field(None, description="mesh triangles, vertex indices")


class BodyModel(BaseModel):
    moving: bool = Field(description="its pose changes (telemetry carries it in `bodies`)")
    pose: list[float] = Field(description="[x y z (m), qw qx qy qz] now, base frame")


class GeometryModel(BaseModel):
    scene: str = Field(description="loaded scene")
    gripper_close_s: float | None = Field(
        None,
        description="[s] its gripper's closing time constant (POST /api/scene); null: no gripper that closes",
    )
    bodies: dict[str, BodyModel] = Field(description="every body by name")
    geoms: list[GeomModel] = Field(description="every visible geom")


class TaskModel(TaskProgressModel):
    scene: str = Field(description="loaded scene")


class StopResult(BaseModel):
    aborted: int | None = Field(description="the command that was running, now `aborted`")
    dropped: list[int] = Field(description="queued commands dropped (ended `aborted`)")


class ErrorModel(BaseModel):
    detail: str = Field(description="what went wrong and what to do, in words")


class FieldErrorModel(BaseModel):
    field: str = Field(description="the field, e.g. `duration` or `translation[1]`; `body` for the whole")
    message: str = Field(description="what is wrong with it, with the allowed range")
    type: str | None = Field(description="pydantic's error type, for programs")


class ValidationErrorModel(BaseModel):
    detail: str = Field(description="`field: message; ...`, to show as it is")
    errors: list[FieldErrorModel] = Field(description="the same, one item per problem")


def _error(description: str) -> dict[str, Any]:
    return {"model": ErrorModel, "description": description}


# Every route can answer these (ptwl/guard/ runs before any route).
COMMON_RESPONSES: dict[int | str, dict[str, Any]] = {
    400: _error("the Host header is not one of the server's names (DNS rebinding guard)"),
    401: _error("a token is set and none was sent (`Authorization: Bearer <token>`)"),
    403: _error("wrong token, or a browser page from an origin that is not allowed"),
    413: _error("request body over 64 KiB"),
    422: {"model": ValidationErrorModel, "description": "a parameter or the body is invalid"},
}
SIM_RESPONSES: dict[int | str, dict[str, Any]] = {
    503: _error("the simulation thread did not answer within 5 s"),
}


QUEUE_FULL_RESPONSES: dict[int | str, dict[str, Any]] = {
    429: {
        "model": ErrorModel,
        "description": "the command queue is full (64): wait, or POST /api/stop",
        "headers": {"Retry-After": {"description": "[s] when to try again", "schema": {"type": "integer"}}},
    },
    503: _error("the command ids cannot be put on record (the robot's --data-dir): nothing was queued"),
}
# OpenAPI links: which request may follow an answer, and with what from it. They document the
# API's flows, and schemathesis's stateful phase follows them (tests/test_openapi_fuzz.py): a
# defect that needs two requests (GET /api/state failed 500 after a PTWL whose gains_frame named
# a task frame) is found only along such a path.
_STATE_LINK = {
    "operationRef": "#/paths/~1api~1state/get",
    "description": "the robot's state, gains included",
}
SUBMIT_RESPONSES: dict[int | str, dict[str, Any]] = {
    202: {
        "description": "queued",
        "links": {
            "StateAfterCommand": _STATE_LINK,
            "FollowCommand": {
                "operationRef": "#/paths/~1api~1commands~1{command_id}/get",
                "parameters": {"path.command_id": "$response.body#/id"},
                "description": "the command's status (`?wait=` until it ends)",
            },
        },
    },
    **QUEUE_FULL_RESPONSES,
}
# After a frame is added: a PTWL whose gains are diagonal in it (then GET /api/state, above).
_GAINS_IN_FRAME = {
    "operationRef": "#/paths/~1api~1commands/post",
    "description": "a PTWL with its stiffness and damping diagonal in the new frame",
    "requestBody": {
        "type": "ptwl",
        "gains_frame": "$response.body#/name",
        "preset": "medium",
        "duration": 0.5,
    },
    "x-schemathesis": {"merge_body": False},  # this body as it is, not mixed with a generated one
}
NOT_FOUND_RESPONSES: dict[int | str, dict[str, Any]] = {
    404: _error("no command with that id (kept: last 1000)")
}


class GainsPreset(BaseModel):
    stiffness: list[float] = Field(description="[N/m x3, N m/rad x3]")
    damping: list[float] = Field(description="[N s/m x3, N m s/rad x3]")
    description: str = ""


class FrameModel(BaseModel):
    """A task frame: its pose in base coordinates; commands use its axes (robot_sim/task_frames.py)."""

    name: str = Field(description="what commands call it in `frame` and `gains_frame`")
    pose: PoseModel = Field(description="origin [m] and axes (quaternion w x y z), base frame")
    source: Literal["scene", "operator"] = Field(
        description="scene: the scene's own, on a fixture (config/frames.toml); operator: added at run time"
    )
    defined_by: str = Field(description="where it came from, in words")


MAX_FRAME_POSITION_M = 2.0  # the arm reaches ~0.6 m: a frame further out is a typing mistake


def _pose_in_reach(pose: PoseModel) -> PoseModel:
    norm = math.hypot(*pose.position)  # no overflow: a sum of squares of 1e200 is inf
    if norm > MAX_FRAME_POSITION_M:
        raise ValueError(
            f"pose.position must be within {MAX_FRAME_POSITION_M:g} m of the base, got {norm:.3g} m"
        )
    return pose


def _unit(quaternion: list[float]) -> list[float]:
    """Normalized once, here (task_frames.unit_quaternion: no overflow, refuses all-zero)."""
    return list(unit_quaternion(quaternion))


class TypedPose(PoseModel):
    model_config = ConfigDict(strict=True, extra="forbid", allow_inf_nan=False)
    position: Annotated[list[float], Field(min_length=3, max_length=3)] = Field(description="[m] base frame")
    quaternion: Annotated[list[float], Field(min_length=4, max_length=4), AfterValidator(_unit)] = Field(
        description="w x y z, base frame (any length but zero; normalized)"
    )


class FrameRequest(BaseModel):
    """A new task frame: the tool's pose now, or a typed pose."""

    model_config = ConfigDict(strict=True, extra="forbid", allow_inf_nan=False)
    name: FrameName = Field(description="letters, digits, _; 1-32 characters, starting with a letter")
    pose: Annotated[TypedPose, AfterValidator(_pose_in_reach)] | Literal["tool"] = Field(
        description="`tool`: the port's pose as the robot has it now; or a pose in base frame"
    )


# A command's status, then the state: by then (`?wait=`) the command has started, and its gains
# are the ones GET /api/state reports.
COMMAND_STATUS_RESPONSES: dict[int | str, dict[str, Any]] = {
    200: {"description": "the command", "links": {"StateAfterCommandStatus": _STATE_LINK}},
    **NOT_FOUND_RESPONSES,
}

DECISION_RESPONSES: dict[int | str, dict[str, Any]] = {
    **COMMAND_STATUS_RESPONSES,
    409: _error("that command is not the running machine, or that decision is not the pending one"),
    422: _error(
        "the body does not validate, or names an outcome or state the machine has not (named in the error)"
    ),
}

FRAME_CONFLICT_RESPONSES: dict[int | str, dict[str, Any]] = {
    409: _error(
        "a frame of that name exists, is built in or the scene's own, queued commands name it, "
        f"or the scene holds its most operator frames ({MAX_OPERATOR_FRAMES})"
    ),
    **SIM_RESPONSES,
}
ADD_FRAME_RESPONSES: dict[int | str, dict[str, Any]] = {
    201: {"description": "added", "links": {"PtwlWithGainsInFrame": _GAINS_IN_FRAME}},
    **FRAME_CONFLICT_RESPONSES,
}
FRAME_NOT_FOUND_RESPONSES: dict[int | str, dict[str, Any]] = {
    404: _error("no task frame of that name"),
    **FRAME_CONFLICT_RESPONSES,
}

"""Task frames: named axes a command's displacement, axes and gains can be given in.

Besides `tool` (the port's axes at the behavior's start) and `base`, a scene names frames on its
fixtures (config/frames.toml: the peg's axis, the plate's normal, the door's hinge), taken from
the fixture where the seed really put it; an operator adds frames from the tool's pose or a
typed pose. A frame is a pose in base coordinates; commands use its axes. A displacement in a
task frame is along those axes, applied at the port, as `base` is.

Frames belong to the loaded scene: a reset brings back the scene's own and drops the operator's.
An operator may add at most MAX_OPERATOR_FRAMES to a scene (the scene's own, from config, do not
count: they are few and fixed by the config file).
"""

import math
from collections.abc import Iterable
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Annotated, Any, Literal, Self

import mujoco
import numpy as np
from ptwl_config import config_dir, read_toml, validation_problem
from pydantic import Field, ValidationError, model_validator

from robot_sim.errors import ConfigError, RobotSimError, UnknownNameError
from robot_sim.gains import Gains
from robot_sim.params import FRAME_FIELDS, StrictModel, Vec3
from robot_sim.pose_math import direction_and_norm, rotation_matrix

BUILT_IN = ("tool", "base")
# Operator frames a scene may hold at once. A task uses a handful (a peg's axis, a contact's
# normal, a few via points); 64 is ample margin and keeps every list a console draws and every
# scene-load message small (~20 KB). Without a cap, 2,000 frames made each add a 286 KB message.
MAX_OPERATOR_FRAMES = 64
Source = Literal["scene", "operator"]


class FrameInUseError(RobotSimError):
    """A frame that cannot be taken away or replaced: a scene's own, or one a command names."""


class FrameLimitError(RobotSimError):
    """The scene holds MAX_OPERATOR_FRAMES operator frames already: one must go first."""


@dataclass(frozen=True)
class TaskFrame:
    name: str
    position: tuple[float, float, float]  # [m] origin, base frame
    quaternion: tuple[float, float, float, float]  # wxyz, the frame's axes in base axes
    source: Source
    defined_by: str  # where it came from, in words: "site peg_top", "tool pose at 3.200 s"

    def rotation(self) -> np.ndarray:
        """(3, 3) R_world_frame: columns are the frame's x, y, z in base axes."""
        return rotation_matrix(np.asarray(self.quaternion, dtype=float))


def unit_quaternion(quaternion: "Iterable[float]") -> tuple[float, float, float, float]:
    """`quaternion` (w x y z, any length) scaled to unit length; ValueError if it has no direction.

    Normalized without overflow (pose_math.direction_and_norm): mju_normalize4 gave [0, 0, 0, 0]
    for [1e200, 0, 0, 0] (a frame whose moves go nowhere) and the identity for 1e-200s."""
    q = [float(v) for v in quaternion]
    if len(q) != 4 or not all(math.isfinite(v) for v in q):
        raise ValueError(f"quaternion must be 4 finite numbers, got {q}")
    (w, x, y, z), norm = direction_and_norm(q)
    if norm == 0.0:
        raise ValueError("quaternion must be non-zero (any length: it is normalized), got [0, 0, 0, 0]")
    return (w, x, y, z)


class TaskFrames:
    """The loaded scene's frames (its own, then the operator's), by name."""

    def __init__(self, frames: Iterable[TaskFrame] = ()) -> None:
        self._frames: dict[str, TaskFrame] = {f.name: f for f in frames}

    def all(self) -> list[TaskFrame]:
        return list(self._frames.values())

    def names(self) -> list[str]:
        """Every name a command may use: the built-in ones first."""
        return [*BUILT_IN, *self._frames]

    def get(self, name: str) -> TaskFrame:
        try:
            return self._frames[name]
        except KeyError:
            raise UnknownNameError("task frame", name, self.names()) from None

    def axes_world(self, name: str, q_world_port: "np.ndarray | list[float]") -> np.ndarray:
        """(3, 3) the named axes in base axes now: the port's for `tool`, I for `base`."""
        if name == "tool":
            return rotation_matrix(np.asarray(q_world_port, dtype=float))
        if name == "base":
            return np.eye(3)
        return self.get(name).rotation()

    def resolve_gains(self, gains: Gains) -> Gains:
        """`gains` with a task frame's axes attached, when they are diagonal in one."""
        if gains.frame in BUILT_IN:
            return gains
        return gains.in_frame(gains.frame, self.get(gains.frame).rotation())

    def unknown_in(self, params: Any) -> dict[str, str]:
        """{field: name} of the frames a command names that do not exist here."""
        known = set(self.names())
        return {f: n for f, n in frames_named(params).items() if n not in known}

    def unknown_errors(self, params: Any) -> list[dict[str, Any]]:
        """A command's unknown frames as pydantic-style errors (the API's 422, the console's check)."""
        valid = ", ".join(self.names())
        return [
            {
                "loc": ("body", field),
                "msg": f"unknown task frame {name!r}; valid: {valid}",
                "type": "value_error",
            }
            for field, name in self.unknown_in(params).items()
        ]

    def missing_reason(self, params: Any) -> str | None:
        """Why a command cannot start here for want of a frame; None when all are here."""
        unknown = self.unknown_in(params)
        if not unknown:
            return None
        said = ", ".join(f"{field} {name!r}" for field, name in unknown.items())
        return f"its task frame is gone ({said}): deleted, or the scene was reset"

    def add(self, frame: TaskFrame) -> None:
        if frame.name in BUILT_IN:
            raise FrameInUseError(f"{frame.name!r} is a built-in frame; choose another name")
        if frame.name in self._frames:
            raise FrameInUseError(
                f"a frame {frame.name!r} exists ({self._frames[frame.name].defined_by}); delete it first"
            )
        if frame.source == "operator" and self.operator_count() >= MAX_OPERATOR_FRAMES:
            raise FrameLimitError(
                f"operator frames: at most {MAX_OPERATOR_FRAMES} per scene, and the scene has "
                f"{MAX_OPERATOR_FRAMES}; delete one before adding {frame.name!r}"
            )
        self._frames[frame.name] = frame

    def operator_count(self) -> int:
        return sum(f.source == "operator" for f in self._frames.values())

    def remove(self, name: str, users: list[int]) -> TaskFrame:
        """Delete an operator's frame, unless commands (`users`, their ids) still name it."""
        if name in BUILT_IN:
            raise FrameInUseError(f"{name!r} is a built-in frame; it cannot be deleted")
        if self.get(name).source == "scene":
            raise FrameInUseError(f"{name!r} is the scene's own frame; it cannot be deleted")
        if users:
            raise FrameInUseError(
                f"{name!r} is named by queued or running commands {users}; stop them or let them end"
            )
        return self._frames.pop(name)


def frame_dict(frame: TaskFrame) -> dict[str, Any]:
    """A frame as the API and telemetry give it (server/models.py FrameModel)."""
    return {
        "name": frame.name,
        "pose": {"position": list(frame.position), "quaternion": list(frame.quaternion)},
        "source": frame.source,
        "defined_by": frame.defined_by,
    }


def frames_from_dicts(frames: "Iterable[dict[str, Any]]") -> TaskFrames:
    """The frames a robot listed (GET /api/frames, or a `frames` telemetry message): a console's copy."""
    return TaskFrames(
        TaskFrame(
            f["name"],
            tuple(f["pose"]["position"]),
            unit_quaternion(f["pose"]["quaternion"]),
            f["source"],
            f["defined_by"],
        )
        for f in frames
    )


def frames_named(params: Any) -> dict[str, str]:
    """{field: frame name} of the frames a command names (none for a state machine)."""
    named = {}
    for field in FRAME_FIELDS:
        value = getattr(params, field, None)
        if isinstance(value, str):
            named[field] = value
    return named


# ---------------------------------------------------------------- the scenes' own, from config
class SceneFrameSpec(StrictModel):
    """A scene's frame on a fixture: a site's pose, or a joint's axis (z) at its anchor; then
    turned by `turn` (a rotation vector in those axes) and moved by `offset` along them."""

    site: str | None = Field(None, description="a site of the scene: the frame is its pose")
    joint: str | None = Field(None, description="a hinge or slide: z along its axis, origin at its anchor")
    turn: Annotated[Vec3, Field()] = Field(default_factory=lambda: [0.0, 0.0, 0.0], description="[rad]")
    offset: Annotated[Vec3, Field()] = Field(default_factory=lambda: [0.0, 0.0, 0.0], description="[m]")
    description: str = ""

    @model_validator(mode="after")
    def _one_source(self) -> Self:
        if (self.site is None) == (self.joint is None):
            raise ValueError("give exactly one of site or joint")
        return self

    def resolve(self, name: str, model: mujoco.MjModel, data: mujoco.MjData) -> TaskFrame:
        """The frame where the loaded (seeded) fixture is: data must be after mj_forward."""
        q = np.zeros(4)
        if self.site is not None:
            site = model.site(self.site)
            mujoco.mju_mat2Quat(q, data.site_xmat[site.id])
            origin = data.site_xpos[site.id].copy()
            defined_by = f"site {self.site}"
        else:
            joint = model.joint(self.joint)
            mujoco.mju_quatZ2Vec(q, data.xaxis[joint.id].copy())
            origin = data.xanchor[joint.id].copy()
            defined_by = f"joint {self.joint}"
        mujoco.mju_quatIntegrate(q, np.asarray(self.turn, dtype=float), 1.0)  # q (x) exp(turn): its own axes
        origin = origin + rotation_matrix(q) @ np.asarray(self.offset, dtype=float)
        x, y, z = origin.tolist()
        return TaskFrame(name, (x, y, z), unit_quaternion(q), "scene", defined_by)


def load_scene_frames(path: Path) -> dict[str, dict[str, SceneFrameSpec]]:
    """{scene: {frame name: spec}} from a frames file; ConfigError names the key and problem."""
    raw = read_toml(path)
    scenes: dict[str, dict[str, SceneFrameSpec]] = {}
    for scene, frames in raw.items():
        scenes[scene] = {}
        for name, table in frames.items():
            if name in BUILT_IN:
                raise ConfigError(f"{path}: [{scene}.{name}] {name!r} is a built-in frame")
            try:
                scenes[scene][name] = SceneFrameSpec.model_validate(table)
            except ValidationError as err:
                raise ConfigError(f"{path}: [{scene}.{name}] {validation_problem(err)}") from None
    return scenes


@cache
def default_scene_frames() -> dict[str, dict[str, SceneFrameSpec]]:
    return load_scene_frames(config_dir() / "frames.toml")


def scene_frames(scene: str, model: mujoco.MjModel, data: mujoco.MjData) -> TaskFrames:
    """The scene's own frames, where its (seeded) fixtures are."""
    specs = default_scene_frames().get(scene, {})
    return TaskFrames(spec.resolve(name, model, data) for name, spec in specs.items())

"""The one definition of each behavior's parameters, reused by the API and the config loader.

Units are SI (m, rad, N, N m, s, Hz); vectors are in base-frame axes unless a field says tool
frame. Every range check names the field, the allowed range and the value it got.
"""

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Annotated, Any, Literal, Self

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    GetCoreSchemaHandler,
    GetJsonSchemaHandler,
    ValidatorFunctionWrapHandler,
    WrapValidator,
    model_validator,
)
from pydantic.json_schema import JsonSchemaValue
from pydantic_core import CoreSchema, core_schema

from robot_sim import limits
from robot_sim.errors import UnknownNameError
from robot_sim.gains import Gains, GainsFrame
from robot_sim.pose_math import direction_and_norm

AxisName = Literal["x", "y", "z", "rx", "ry", "rz"]
AXIS_NAMES: tuple[AxisName, ...] = ("x", "y", "z", "rx", "ry", "rz")


class _Range:
    """lo <= v <= hi (open ends as told); NaN and infinities are refused with the same message.

    The one rule for a number's range: it validates, and it writes the same bounds into the
    JSON schema, so the OpenAPI document says what the server enforces."""

    def __init__(self, lo: float, hi: float, unit: str, *, lo_open: bool = False, hi_open: bool = False):
        self.lo, self.hi, self.lo_open, self.hi_open = lo, hi, lo_open, hi_open
        self.text = f"{'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'} {unit}".rstrip()

    def _check(self, value: Any, handler: ValidatorFunctionWrapHandler) -> float:
        if isinstance(value, float) and not math.isfinite(value):
            raise ValueError(f"must be a finite number in {self.text}, got {value}")
        number = handler(value)
        too_low = number <= self.lo if self.lo_open else number < self.lo
        too_high = number >= self.hi if self.hi_open else number > self.hi
        if too_low or too_high:
            raise ValueError(f"must be in {self.text}, got {number:g}")
        return float(number)

    def __get_pydantic_core_schema__(self, source: Any, handler: GetCoreSchemaHandler) -> CoreSchema:
        return core_schema.no_info_wrap_validator_function(self._check, handler(source))

    def __get_pydantic_json_schema__(
        self, schema: CoreSchema, handler: GetJsonSchemaHandler
    ) -> JsonSchemaValue:
        json_schema = handler(schema)
        if math.isfinite(self.lo):
            json_schema["exclusiveMinimum" if self.lo_open else "minimum"] = self.lo
        if math.isfinite(self.hi):
            json_schema["exclusiveMaximum" if self.hi_open else "maximum"] = self.hi
        return json_schema


_range = _Range


def _vector(limit: float, unit: str, *, direction: bool = False) -> WrapValidator:
    """Finite components and magnitude <= limit; a `direction` must be non-zero and is returned
    as a unit vector (the one place it is normalized)."""

    def check(value: Any, handler: ValidatorFunctionWrapHandler) -> list[float]:
        if isinstance(value, list | tuple):
            for i, v in enumerate(value):
                if isinstance(v, float) and not math.isfinite(v):
                    raise ValueError(f"component {i} must be a finite number, got {v}")
        vec: list[float] = handler(value)
        unit_vec, norm = direction_and_norm(vec)  # [1.7e308, 1.7e308, 0] has no float norm
        if norm > limit:
            raise ValueError(f"magnitude must be <= {limit:g} {unit}, got {norm:.4g}")
        if direction:
            if norm < 1e-9:
                raise ValueError("must be a non-zero direction")
            return unit_vec
        return vec

    return WrapValidator(check)


Vec3 = Annotated[list[float], Field(min_length=3, max_length=3)]
Vec6 = Annotated[list[float], Field(min_length=6, max_length=6), _vector(math.inf, "")]
Duration = Annotated[float, _range(0.0, limits.MAX_DURATION_S, "s", lo_open=True)]
GripperCloseTime = Annotated[float, _range(*limits.GRIPPER_CLOSE_S, "s")]  # a scene's, POST /api/scene
# Tolerances: a PTWL moves at most MAX_TRANSLATION_M and an orientation error is at most pi, so
# a wider tolerance says nothing more (1e308 m was accepted).
PositionTolerance = Annotated[float, _range(0.0, limits.MAX_TRANSLATION_M, "m", lo_open=True)]
OrientationTolerance = Annotated[float, _range(0.0, limits.MAX_ROTATION_RAD, "rad", lo_open=True)]
ForceThreshold = Annotated[float, _range(0.0, limits.MAX_FORCE_THRESHOLD_N, "N", lo_open=True)]
TorqueThreshold = Annotated[float, _range(0.0, limits.MAX_TORQUE_THRESHOLD_NM, "N m", lo_open=True)]


def _type_required(schema: dict[str, Any]) -> None:
    """`type` has a default for Python callers (PtwlParams() is a PTWL), but an API body must
    name its behavior: the schema says so."""
    required = schema.setdefault("required", [])
    if "type" in schema.get("properties", {}) and "type" not in required:
        required.insert(0, "type")


class StrictModel(BaseModel):
    # NaN and infinities are refused everywhere; unknown fields are errors, not silently dropped;
    # strict: `true` or "5" is not a number (JSON ints are still fine where floats are asked).
    model_config = ConfigDict(
        allow_inf_nan=False, extra="forbid", strict=True, json_schema_extra=_type_required
    )


OnBreach = Literal["limit", "freeze"]
ON_BREACH_DOC = (
    "where the attractor goes on a wrench breach: `limit` holds the threshold (default); "
    "`freeze` leaves it where it was (the paper's rule: the held force can pass the threshold)"
)
GAINS_FRAME_DOC = "axes K and B are diagonal in: `base`, or `tool` (the port's axes, turning with it)"

# `tool`, `base`, or a task frame's name (robot_sim/task_frames.py; GET /api/frames lists them).
# Whether the name exists is the robot's to say: frames belong to the loaded scene.
FRAME_NAME_PATTERN = r"^[A-Za-z][A-Za-z0-9_]{0,31}$"
FrameName = Annotated[str, Field(pattern=FRAME_NAME_PATTERN, min_length=1, max_length=32)]
FRAME_FIELDS = ("frame", "gains_frame")  # the fields of a command that name a frame
TASK_FRAME_DOC = ", or a task frame's name (GET /api/frames)"


@dataclass
class NamedElsewhere:
    """The names a request may use that this module does not own: stiffness and dither presets
    (robot_sim/presets.py) and tasks (robot_sim/policies/), each registered here by its owner
    when robot_sim is imported (robot_sim/__init__.py). Those build on these params, so this
    module imports neither: the arrows point one way."""

    stiffness_preset: "Callable[[str], GainsSpec] | None" = None  # UnknownNameError if unknown
    dither_preset: Callable[[str], dict[str, Any]] | None = None
    task_settings: Callable[[str], type[BaseModel]] | None = None  # a task's settings model
    tasks: Callable[[], Iterable[str]] | None = None

    def need(self, lookup: Callable[..., Any] | None, what: str) -> Callable[..., Any]:
        if lookup is None:  # robot_sim/__init__.py registers all: only a broken install gets here
            raise RuntimeError(f"no {what} registered with robot_sim.params")
        return lookup


NAMED = NamedElsewhere()


class GainsSpec(StrictModel):
    """Diagonal stiffness and damping on axes x y z rx ry rz of `frame`, within the stable range."""

    stiffness: Vec6 = Field(description="[N/m x3, N m/rad x3], >= 0; see limits.py for the range")
    damping: Vec6 = Field(description="[N s/m x3, N m s/rad x3], > 0; see limits.py for the range")
    frame: GainsFrame = Field("base", description=GAINS_FRAME_DOC)

    @model_validator(mode="after")
    def _stable(self) -> Self:
        limits.check_gains(self.stiffness, self.damping)
        return self

    def to_gains(self) -> Gains:
        return Gains.of(self.stiffness, self.damping, self.frame)


class MonitorSpec(StrictModel):
    """The force task monitor (the teleoperation paper's 2.4.1, with 2.5.2's estimator): while
    the port slides in contact, the force along the surface is modelled as mu |F_n| + c and
    (mu, c) are tracked by recursive least squares, one forgetting factor each; once learned, a
    measured force outside the model's band for `persist` ends the behavior `anomaly` (a jam, a
    change of surface), and a measurement outside the band is never learned from."""

    model: Literal["friction"] = Field(
        "friction", description="friction: tangential force = mu |normal force| + c while sliding"
    )
    normal: Annotated[Vec3, _vector(math.inf, "", direction=True)] = Field(
        default_factory=lambda: [0.0, 0.0, 1.0], description="the surface normal, base axes (normalized)"
    )
    forgetting: Annotated[list[Annotated[float, _range(0.5, 1.0, "")]], Field(min_length=2, max_length=2)] = (
        Field(
            default_factory=lambda: [0.999, 0.995],
            description="[mu, c] per 10 ms sample, [0.5, 1]: mu remembers ~10 s, c ~2 s (factors far "
            "apart, e.g. 0.98 for c, let c absorb a changing normal force and mu drift)",
        )
    )
    band_fraction: Annotated[float, _range(0.0, 5.0, "", lo_open=True)] = Field(
        0.3, description="anomaly when |measured - predicted| > this x |predicted| (the paper's 30 %)"
    )
    band_min: Annotated[float, _range(0.0, limits.MAX_FORCE_THRESHOLD_N, "N", lo_open=True)] = Field(
        1.0, description="[N] and > this (a floor, so a light touch is not judged by its noise)"
    )
    min_normal_force: Annotated[float, _range(0.0, limits.MAX_FORCE_THRESHOLD_N, "N")] = Field(
        1.0, description="[N] in contact above this; judged and learned only in contact"
    )
    min_speed: Annotated[float, _range(0.0, 1.0, "m/s", lo_open=True)] = Field(
        0.002, description="[m/s] sliding above this along the surface; judged and learned only then"
    )
    warmup: Annotated[float, _range(0.0, 60.0, "s")] = Field(
        0.3, description="[s] of sliding in contact spent learning before judging"
    )
    persist: Annotated[float, _range(0.0, 5.0, "s")] = Field(
        0.03, description="[s] outside the band this long is an anomaly (one noisy sample is not)"
    )


MONITOR_DOC = "force task monitor (opt-in): ends the behavior `anomaly` when contact forces leave its model"


MAX_AGE_S = 86400.0
MAX_SIM_TIME_S = 1e9  # [s] ~32 years of sim time since a scene load: past any run's
EXPIRY_DOC = (
    "a command that has not started by then ends `expired` without moving the robot (a command "
    "held in a link blackout must not act on a world that has moved on)"
)


class Expiring(StrictModel):
    """When a command stops being worth running: by the sender's age or by the robot's sim time.

    Judged by the robot as the command is about to start (expiry_reason), so a command that waited
    in the link or in the queue is judged alike. `max_age` compares the robot's wall clock with
    the sender's `sent_at`: across machines their clocks must agree to well under `max_age`."""

    # The robot refuses a sent_at more than its skew (limits.SENT_AT_SKEW_S by default) ahead of its
    # own clock (server/commands.py: the bound moves with the clock, so the schema cannot hold it).
    sent_at: Annotated[float, _range(0.0, math.inf, "s", hi_open=True)] | None = Field(
        None,
        description="[s] Unix time when the sender sent it, by the sender's clock; at most the "
        f"robot's clock + {limits.SENT_AT_SKEW_S:g} s (its --sent-at-skew)",
    )
    max_age: Annotated[float, _range(0.0, MAX_AGE_S, "s", lo_open=True)] | None = Field(
        None, description="[s] (0, 86400] after `sent_at`, which it needs; " + EXPIRY_DOC
    )
    valid_until_sim_time: Annotated[float, _range(0.0, MAX_SIM_TIME_S, "s")] | None = Field(
        None, description="[s] the robot's sim time, [0, 1e9]; " + EXPIRY_DOC
    )

    @model_validator(mode="after")
    def _age_has_a_start(self) -> Self:
        if self.max_age is not None and self.sent_at is None:
            raise ValueError("max_age needs sent_at (the sender's Unix time when it sent the command)")
        return self

    def expiry_reason(self, now_unix_s: float, sim_time_s: float) -> str | None:
        """Why this command must not start now; None while it is still valid."""
        if self.max_age is not None and self.sent_at is not None:
            age_s = now_unix_s - self.sent_at
            if age_s > self.max_age:
                return f"{age_s:.2f} s old at its start, over its max_age {self.max_age:g} s"
        until_s = self.valid_until_sim_time
        if until_s is not None and sim_time_s > until_s:
            return f"sim time {sim_time_s:.3f} s at its start, past valid_until_sim_time {until_s:g} s"
        return None


class PtwlParams(Expiring):
    """Pose Target Wrench Limiting: move the attractor to port (+) displacement over `duration`."""

    type: Literal["ptwl"] = Field("ptwl", description="behavior: ptwl")
    translation: Annotated[Vec3, _vector(limits.MAX_TRANSLATION_M, "m")] = Field(
        default_factory=lambda: [0.0, 0.0, 0.0], description="[m], in `frame`; |t| <= 1 m"
    )
    rotation: Annotated[Vec3, _vector(limits.MAX_ROTATION_RAD, "rad")] = Field(
        default_factory=lambda: [0.0, 0.0, 0.0], description="rotation vector [rad] in `frame`; |r| <= pi"
    )
    frame: FrameName = Field(
        "tool",
        description="axes of translation and rotation: `tool` (the port's at start), `base`" + TASK_FRAME_DOC,
    )
    duration: Duration = Field(2.0, description="[s] attractor travel time, (0, 600]")
    force_threshold: ForceThreshold = Field(20.0, description="[N] |f| above this ends wrench_breach; <= 500")
    torque_threshold: TorqueThreshold = Field(
        2.0, description="[N m] |tau| above this ends wrench_breach; <= 50"
    )
    position_tolerance: PositionTolerance = Field(
        0.002, description="[m] goal_reached when within this; (0, 1]"
    )
    orientation_tolerance: OrientationTolerance = Field(0.02, description="[rad] and within this; (0, pi]")
    watchdog: Duration | None = Field(None, description="[s] timeout; >= duration; default duration + 5")
    on_breach: OnBreach = Field("limit", description=ON_BREACH_DOC)
    preset: str | None = Field(None, description="stiffness/damping preset name")
    stiffness: Vec6 | None = Field(None, description="explicit [N/m x3, N m/rad x3], with damping")
    damping: Vec6 | None = Field(None, description="explicit [N s/m x3, N m s/rad x3], with stiffness")
    gains_frame: FrameName | None = Field(
        None,
        description=GAINS_FRAME_DOC + TASK_FRAME_DOC + "; default: the preset's, else base (explicit), "
        "else unchanged",
    )
    monitor: MonitorSpec | None = Field(None, description=MONITOR_DOC)

    @model_validator(mode="after")
    def _consistent(self) -> Self:
        if self.watchdog is None:
            self.watchdog = self.duration + 5.0
        elif self.watchdog < self.duration:
            raise ValueError(f"watchdog ({self.watchdog:g} s) must be >= duration ({self.duration:g} s)")
        _check_gains_choice(self.preset, self.stiffness, self.damping)
        return self

    def gains(self, current: Gains) -> Gains:
        """The gains for this move: the preset's or the explicit ones, else `current`; in
        `gains_frame` when given."""
        chosen = _resolve_gains(self.preset, self.stiffness, self.damping) or current
        return chosen if self.gains_frame is None else chosen.in_frame(self.gains_frame)


class RweParams(Expiring):
    """Reset Wrench Equilibrium on the selected axes; the others keep their stretch."""

    type: Literal["rwe"] = Field("rwe", description="behavior: rwe")
    axes: list[AxisName] = Field(
        default_factory=lambda: list(AXIS_NAMES), min_length=1, description="axes to relieve"
    )
    duration: Duration = Field(1.0, description="[s] how long the attractor tracks the port, (0, 600]")
    frame: FrameName = Field(
        "base", description="axes of `axes`: `base`, `tool` (the port's at start)" + TASK_FRAME_DOC
    )
    force_residual: ForceThreshold = Field(
        1.0, description="[N] relieved when |f| on the axes is below; <= 500"
    )
    torque_residual: TorqueThreshold = Field(0.1, description="[N m] and |tau| on the axes is below; <= 50")

    @model_validator(mode="after")
    def _unique(self) -> Self:
        if len(set(self.axes)) != len(self.axes):
            raise ValueError(f"axes must not repeat, got {self.axes}")
        return self

    def axis_mask(self) -> list[bool]:
        return [name in self.axes for name in AXIS_NAMES]


class DitherParams(Expiring):
    """Dither: wiggle the attractor while advancing (push) or retreating (pull) along an axis."""

    type: Literal["dither"] = Field("dither", description="behavior: dither")
    preset: str | None = Field(None, description="one of the dither presets; other fields override it")
    mode: Literal["torsional", "translational"] = Field(
        "torsional",
        description="torsional: turn back and forth about the axis, origin on it; translational: "
        "the origin circles the axis, orientation fixed",
    )
    direction: Literal["push", "pull"] = Field("push", description="advance along the axis, or retreat")
    axis: Annotated[Vec3, _vector(math.inf, "", direction=True)] = Field(
        default_factory=lambda: [0.0, 0.0, 1.0], description="direction in `frame` (any length; normalized)"
    )
    frame: FrameName = Field(
        "tool", description="axes of `axis`: `tool` (the port's at start), `base`" + TASK_FRAME_DOC
    )
    amplitude: Annotated[float, _range(0.0, limits.MAX_DITHER_AMPLITUDE, "rad or m", lo_open=True)] = Field(
        0.03, description="[rad] turn (torsional) or [m] circle radius (translational)"
    )
    frequency: Annotated[float, _range(0.0, limits.MAX_DITHER_FREQUENCY_HZ, "Hz", lo_open=True)] = Field(
        1.0, description="[Hz] wiggle frequency"
    )
    travel: Annotated[float, _range(0.0, limits.MAX_TRANSLATION_M, "m")] = Field(
        0.01, description="[m] distance along the axis"
    )
    duration: Duration = Field(4.0, description="[s] time to cover `travel`, (0, 600]")
    progress: Annotated[float, _range(limits.MIN_DITHER_PROGRESS_M, limits.MAX_TRANSLATION_M, "m")] | None = (
        Field(
            None,
            description="[m] the port's advance along the axis that ends it `goal_reached` (a jam "
            "freed), <= travel; null: the travel. Ends within 1 mm of it (the travel's tolerance), "
            "the attractor still ahead: the push it leaves is relieved by an RWE",
        )
    )
    force_threshold: ForceThreshold = Field(30.0, description="[N] <= 500")
    torque_threshold: TorqueThreshold = Field(3.0, description="[N m] <= 50")
    watchdog: Duration | None = Field(None, description="[s] >= duration; default duration + 5")
    on_breach: OnBreach = Field("limit", description=ON_BREACH_DOC)
    monitor: MonitorSpec | None = Field(None, description=MONITOR_DOC)

    @model_validator(mode="before")
    @classmethod
    def _apply_preset(cls, data: object) -> object:
        """A named preset supplies every field the request does not give."""
        if isinstance(data, dict) and data.get("preset") is not None:
            try:
                base = NAMED.need(NAMED.dither_preset, "dither presets")(str(data["preset"]))
            except UnknownNameError as err:
                raise ValueError(str(err)) from None
            return {**base, **data}
        return data

    @model_validator(mode="after")
    def _consistent(self) -> Self:
        if self.mode == "translational" and self.amplitude > limits.MAX_DITHER_RADIUS_M:
            raise ValueError(
                f"amplitude must be in (0, {limits.MAX_DITHER_RADIUS_M:g}] m for translational mode, "
                f"got {self.amplitude:g}"
            )
        if self.watchdog is None:
            self.watchdog = self.duration + 5.0
        elif self.watchdog < self.duration:
            raise ValueError(f"watchdog ({self.watchdog:g} s) must be >= duration ({self.duration:g} s)")
        if self.progress is not None and self.progress > self.travel:
            raise ValueError(f"progress ({self.progress:g} m) must be <= travel ({self.travel:g} m)")
        return self


def _check_gains_choice(
    preset: str | None, stiffness: list[float] | None, damping: list[float] | None
) -> None:
    if preset is not None and (stiffness is not None or damping is not None):
        raise ValueError("give either preset or stiffness/damping, not both")
    if (stiffness is None) != (damping is None):
        raise ValueError("stiffness and damping go together: give both or neither")
    if stiffness is not None and damping is not None:
        limits.check_gains(stiffness, damping)
    if preset is not None:
        try:
            NAMED.need(NAMED.stiffness_preset, "stiffness presets")(preset)
        except UnknownNameError as err:
            raise ValueError(str(err)) from None


def _resolve_gains(
    preset: str | None, stiffness: list[float] | None, damping: list[float] | None
) -> Gains | None:
    if preset is not None:
        spec: GainsSpec = NAMED.need(NAMED.stiffness_preset, "stiffness presets")(preset)
        return spec.to_gains()
    if stiffness is not None and damping is not None:
        return Gains.of(stiffness, damping)
    return None


class GripperParams(Expiring):
    """Close or open the gripper (paper 2.3.3-2.3.4): not a compliant behavior, but a step of the
    tool tasks; the attractor holds still while the jaws move."""

    type: Literal["gripper"] = Field("gripper", description="command: gripper")
    action: Literal["close", "open"] = Field(
        description="close: grasp what is between the jaws; open: let go"
    )
    duration: Annotated[float, _range(0.0, limits.MAX_GRIPPER_S, "s", lo_open=True)] = Field(
        0.5, description="[s] the jaws' travel and settling time, (0, 5]"
    )

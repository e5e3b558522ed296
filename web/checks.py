"""A command checked before Send, by the robot's own rules: the API's request models validate it
(ranges, watchdog >= duration, stable gains, presets, task frames) and robot_sim.impact says whether the
approach would overshoot its thresholds on contact. No rule is restated here; the robot still
checks everything again when the command arrives."""

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from pydantic import ValidationError

from robot_sim.command_request import COMMAND, error_detail, field_errors
from robot_sim.executor import CommandParams
from robot_sim.gains import Gains
from robot_sim.params import PtwlParams
from robot_sim.ptwl_warnings import move_warnings
from robot_sim.task_frames import TaskFrames


@dataclass(frozen=True)
class Check:
    errors: str = ""  # as the API's 422 would say it; empty when valid
    warnings: list[str] = field(default_factory=list)
    params: CommandParams | None = None  # as validated, defaults filled in
    # The same refusals as the API's 422 lists them, {"field", "message", "type"} each: the
    # console says each at the field it names, in that field's units.
    by_field: list[dict[str, Any]] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not self.errors


def check_command(
    behavior: str,
    params: dict[str, Any],
    gains_now: Gains | None,
    q_world_port: np.ndarray | None,
    frames: TaskFrames,
) -> Check:
    try:
        validated = COMMAND.validate_python({"type": behavior, **params})
    except ValidationError as err:
        return _refused(field_errors(list(err.errors())))  # type: ignore[arg-type]
    unknown_frames = frames.unknown_errors(validated)
    if unknown_frames:
        return _refused(field_errors(unknown_frames))
    warnings: list[str] = []
    if isinstance(validated, PtwlParams) and q_world_port is not None and gains_now is not None:
        warnings = move_warnings(validated, gains_now, q_world_port, frames)
    return Check(warnings=warnings, params=validated)


def _refused(items: list[dict[str, Any]]) -> Check:
    return Check(errors=error_detail(items), by_field=items)

"""What a non-finite number (a simulation fault's NaN or inf) becomes in what we publish: null,
so the API's answers, the telemetry and the recordings stay strict JSON for every reader. A
vector with one non-finite element is null as a whole: a wrench or a pose with a hole in it is
not one."""

import math
from collections.abc import Sequence
from typing import Any

from robot_sim.behaviors.base import BehaviorReport, ExitCondition, Pose


def finite_or_none(value: float) -> float | None:
    return value if math.isfinite(value) else None


def finite_vector_or_none(values: Sequence[float]) -> list[float] | None:
    return [float(v) for v in values] if all(math.isfinite(v) for v in values) else None


def finite_json(value: Any) -> Any:
    """`value` (dicts, lists, numbers, ...) with the rule above applied throughout."""
    if isinstance(value, float):
        return finite_or_none(value)
    if isinstance(value, dict):
        return {k: finite_json(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        if value and all(isinstance(v, int | float) and not isinstance(v, bool) for v in value):
            return finite_vector_or_none(value)
        return [finite_json(v) for v in value]
    return value


def number_or_nan(value: float | None) -> float:
    """A published number read back: null (a non-finite one, by the rule above) is NaN, never a
    measured 0."""
    return math.nan if value is None else float(value)


def report_from_json(fields: dict[str, Any], started_at_s: float, ended_at_s: float) -> BehaviorReport:
    """A BehaviorReport from the JSON it was published as (an API record or event, a recorded
    step), with the rule above undone: what was null reads back as NaN."""
    port = fields.get("final_port") or {"position": [math.nan] * 3, "quaternion": [math.nan] * 4}
    wrench = fields.get("final_wrench") or [math.nan] * 6
    return BehaviorReport(
        behavior=fields.get("behavior") or fields["type"],
        exit=ExitCondition(fields["exit"]),
        started_at=started_at_s,
        ended_at=ended_at_s,
        peak_force=number_or_nan(fields.get("peak_force")),
        peak_torque=number_or_nan(fields.get("peak_torque")),
        final_wrench=tuple(float(v) for v in wrench),
        final_port=Pose.of(port["position"], port["quaternion"]),
        detail=fields.get("detail") or "",
    )

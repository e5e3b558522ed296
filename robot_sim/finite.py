"""What a non-finite number (a simulation fault's NaN or inf) becomes in what we publish: null,
so the API's answers, the telemetry and the recordings stay strict JSON for every reader. A
vector with one non-finite element is null as a whole: a wrench or a pose with a hole in it is
not one."""

import math
from collections.abc import Sequence
from typing import Any


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

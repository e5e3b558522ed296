"""Schedules from files: our TOML (a `Schedule` table), or an ION-DTN contact plan.

An ION plan is ionadmin commands, one per line; two are read, with times relative to when the
plan is loaded (`+seconds`):
    a contact +START +END FROM TO RATE      RATE in bytes/s: a window the link carries FROM -> TO
    a range +START +END FROM TO OWLT        OWLT in s: the one-way light time in that interval
Uplink is ground -> robot, downlink robot -> ground; a range holds both ways (as in ION). Other
ionadmin commands (`m`, `s`, `1`, comments `#`) are skipped; a contact or range line that does
not parse, or an absolute time (`2026/11/27-12:00:00`), is refused naming its line.
"""

import tomllib
from pathlib import Path
from typing import Any

from ptwl_config import PtwlError
from pydantic import ValidationError

from latency.schedule import Schedule

MAX_PLAN_FILE_BYTES = 4 * 2**20


class PlanFileError(PtwlError, ValueError):
    """A schedule or contact plan file that cannot be read or does not validate."""


def _seconds(token: str, path: str, line_no: int) -> float:
    if not token.startswith("+"):
        raise PlanFileError(
            f"{path}:{line_no}: time {token!r} is absolute; only relative times (+seconds) are read"
        )
    try:
        return float(token[1:])
    except ValueError:
        raise PlanFileError(f"{path}:{line_no}: time {token!r} is not +seconds") from None


def _number(token: str, what: str, path: str, line_no: int) -> float:
    try:
        return float(token)
    except ValueError:
        raise PlanFileError(f"{path}:{line_no}: {what} {token!r} is not a number") from None


def from_ion(text: str, ground_node: int = 1, robot_node: int = 2, path: str = "<plan>") -> dict[str, Any]:
    """The Schedule fields (unvalidated) an ION contact plan gives between two nodes."""
    directions = {(ground_node, robot_node): "uplink", (robot_node, ground_node): "downlink"}
    contacts: list[dict[str, Any]] = []
    ranges: list[tuple[float, float, float]] = []
    for line_no, raw in enumerate(text.splitlines(), start=1):
        words = raw.split("#", 1)[0].split()
        if words[:2] not in (["a", "contact"], ["a", "range"]):
            continue
        if len(words) not in (7, 8):  # newer ION adds a confidence to a contact
            raise PlanFileError(f"{path}:{line_no}: `{' '.join(words[:2])}` needs +START +END FROM TO VALUE")
        start, end = _seconds(words[2], path, line_no), _seconds(words[3], path, line_no)
        try:
            pair = (int(words[4]), int(words[5]))
        except ValueError:
            raise PlanFileError(
                f"{path}:{line_no}: node numbers must be integers, got {words[4:6]}"
            ) from None
        value = _number(words[6], "rate" if words[1] == "contact" else "owlt", path, line_no)
        if words[1] == "contact" and pair in directions:
            contacts.append(
                {"start": start, "end": end, "direction": directions[pair], "rate_bytes_per_s": value}
            )
        elif words[1] == "range" and set(pair) == {ground_node, robot_node}:
            ranges.append((start, end, value))
    if not contacts:
        raise PlanFileError(f"{path}: no contact between nodes {ground_node} and {robot_node}")
    delay = []
    for start, end, owlt in sorted(set(ranges)):
        delay += [{"at": start, "one_way_s": owlt}, {"at": end, "one_way_s": owlt}]
    return {"contacts": contacts, "delay": delay}


def read_schedule(path: Path, ground_node: int = 1, robot_node: int = 2) -> Schedule:
    """A `.toml` schedule, or any other file read as an ION contact plan."""
    try:
        if path.stat().st_size > MAX_PLAN_FILE_BYTES:
            raise PlanFileError(f"{path}: larger than {MAX_PLAN_FILE_BYTES} bytes")
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as err:
        raise PlanFileError(f"{path}: {err}") from None
    try:
        fields = (
            tomllib.loads(text)
            if path.suffix == ".toml"
            else from_ion(text, ground_node, robot_node, str(path))
        )
    except tomllib.TOMLDecodeError as err:
        raise PlanFileError(f"{path}: {err}") from None
    try:
        return Schedule.model_validate(fields)
    except ValidationError as err:
        first = err.errors()[0]
        where = ".".join(str(p) for p in first["loc"]) or "schedule"
        raise PlanFileError(f"{path}: {where}: {str(first['msg']).removeprefix('Value error, ')}") from None

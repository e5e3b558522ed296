"""The API's command request and how a refusal of one is said: the one pydantic union the robot
validates a POST /api/commands body with, and pydantic's errors as `{"field", "message", "type"}`.
Free of FastAPI and the server, so the console checks a command before Send by the same models
and says each refusal in the same words (web/checks.py)."""

import re
from typing import Annotated, Any

from pydantic import Field, TypeAdapter

from robot_sim.executor import CommandParams
from robot_sim.machines.command import StateMachineParams
from robot_sim.params import DitherParams, GripperParams, PtwlParams, RweParams

Command = Annotated[
    PtwlParams | RweParams | DitherParams | GripperParams | StateMachineParams, Field(discriminator="type")
]
COMMAND: TypeAdapter[CommandParams] = TypeAdapter(Command)

_TAGS = {"ptwl", "rwe", "dither"}


# pydantic's label for a validator-wrapped union member (`function-after[_pose_in_reach(),
# TypedPose]`): not a field, so `pose.quaternion` reads as the client wrote it.
_WRAPPER = re.compile(r"^function-(after|before|wrap|plain)\[.*\]$")


def _field(loc: tuple[Any, ...]) -> str:
    """`body.ptwl.duration` -> `duration`; list indices as `translation[1]`."""
    parts = [
        p for p in loc if p not in ("body", "query", "path") and p not in _TAGS and not _WRAPPER.match(str(p))
    ]
    text = ""
    for part in parts:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else str(part))
    return text or "body"


def _message(err: dict[str, Any]) -> str:
    msg = str(err.get("msg", "invalid")).removeprefix("Value error, ")
    if err.get("type") == "json_invalid":
        ctx = err.get("ctx") or {}
        return f"malformed JSON: {ctx.get('error', msg)}"
    if err.get("type") == "union_tag_invalid":
        return msg + " (field `type`)"
    return msg


def field_errors(errors: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Pydantic errors as the API reports them: `{"field", "message", "type"}` each (also used by
    the console to check a command before sending it)."""
    return [
        {"field": _field(tuple(e.get("loc", ()))), "message": _message(e), "type": e.get("type")}
        for e in errors
    ]


def error_detail(items: list[dict[str, Any]]) -> str:
    return "; ".join(f"{i['field']}: {i['message']}" for i in items)

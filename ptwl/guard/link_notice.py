"""What the link tells the robot of its downlink, so the robot sends no more states than it
carries: `{"type": "link", "downlink_bytes_per_s": R}` (null: unlimited), sent by the proxy on a
relayed telemetry socket at the robot's end, undelayed (the spacecraft's radio knows its own
rate). R is the socket's share of the downlink now; the proxy tells it again when it changes.
The one place for this message, for both ends."""

import json

from pydantic import BaseModel, ConfigDict, Field, ValidationError

MAX_NOTICE_CHARS = 256
MAX_RATE = 1e12  # [bytes/s] the most a link's rate may be (latency/schedule.py's bound too)
MIN_RATE = 1.0  # [bytes/s] the least a link's rate may be
MIN_SHARE = 1e-6  # [bytes/s] the least a notice tells: a socket's share of the slowest link


class LinkNotice(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False)
    type: str = Field(pattern="^link$")
    downlink_bytes_per_s: float | None = Field(ge=MIN_SHARE, le=MAX_RATE)


def notice_text(downlink_bytes_per_s: float | None) -> str:
    return json.dumps({"type": "link", "downlink_bytes_per_s": downlink_bytes_per_s})


def is_notice(text: str) -> bool:
    return text.startswith('{"type": "link"')


def parse_notice(text: str) -> float | None:
    """The rate a notice tells; ValueError naming the field and its range if it is no notice."""
    if len(text) > MAX_NOTICE_CHARS:
        raise ValueError(f"a link notice is at most {MAX_NOTICE_CHARS} characters")
    try:
        return LinkNotice.model_validate_json(text).downlink_bytes_per_s
    except ValidationError as err:
        first = err.errors()[0]
        where = ".".join(str(p) for p in first["loc"]) or "notice"
        raise ValueError(
            f"link notice {where}: {first['msg']} "
            f"(downlink_bytes_per_s: [{MIN_SHARE:g}, {MAX_RATE:g}] or null)"
        ) from None

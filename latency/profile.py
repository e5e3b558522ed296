"""Link profiles: delays, jitter, loss, blackouts and buffer caps, as pydantic models.

Units: seconds. Delays are one-way (`uplink`: operator to robot, `downlink`: robot to operator);
the round trip is their sum. Blackout windows are timed from the moment the profile takes
effect (a PUT, or the proxy's start), optionally repeating every `period`.
"""

import math
from typing import Annotated, Any, Literal, Self

from pydantic import Field, model_validator

from latency.fields import MAX_DELAY_S, Seconds, StrictModel
from latency.schedule import Rate, Schedule

Probability = Annotated[float, Field(ge=0.0, le=1.0)]
Seed = Annotated[int, Field(ge=0, le=2**32 - 1)]
MAX_DESCRIPTION_CHARS = 2000


class Jitter(StrictModel):
    """Per-message delay variation added to the base delay (clipped at zero total delay)."""

    distribution: Literal["none", "uniform", "normal"] = Field(
        "none", description="uniform: +-amount; normal: standard deviation amount"
    )
    amount: Seconds = Field(0.0, description="[s] half-width (uniform) or standard deviation (normal)")
    seed: Seed = Field(0, description="random seed: the same seed gives the same delays")


class Loss(StrictModel):
    """Whole-message loss (WebSocket messages; HTTP rides a reliable channel)."""

    model: Literal["none", "bernoulli", "gilbert_elliott"] = Field("none", description="loss process")
    probability: Probability = Field(0.0, description="bernoulli: chance each message is lost")
    p_good_to_bad: Probability = Field(
        0.0, description="gilbert_elliott: per-message chance to enter the bad state"
    )
    p_bad_to_good: Probability = Field(1.0, description="gilbert_elliott: per-message chance to leave it")
    loss_in_good: Probability = Field(0.0, description="gilbert_elliott: loss chance in the good state")
    loss_in_bad: Probability = Field(1.0, description="gilbert_elliott: loss chance in the bad state")
    seed: Seed = Field(0, description="random seed")


class Blackout(StrictModel):
    """A loss-of-signal window. `hold`: messages sent during it wait at the sender and go when it
    ends (store and forward); `drop`: they are lost."""

    start: Seconds = Field(description="[s] after the profile takes effect")
    duration: Annotated[float, Field(gt=0.0, le=MAX_DELAY_S)] = Field(description="[s]")
    mode: Literal["hold", "drop"] = Field("hold", description="hold (store and forward) or drop")
    period: Annotated[float, Field(gt=0.0, le=86400.0)] | None = Field(
        None, description="[s] repeat every period (e.g. an orbit); null for once"
    )

    @model_validator(mode="after")
    def _fits_period(self) -> Self:
        if self.period is not None and self.duration >= self.period:
            raise ValueError(
                f"duration ({self.duration:g} s) must be shorter than period ({self.period:g} s)"
            )
        return self

    def next_start(self, t: float) -> float | None:
        """The first window start after time `t` [s since activation] (None: no more)."""
        if t < self.start:
            return self.start
        if self.period is None:
            return None
        return self.start + (math.floor((t - self.start) / self.period) + 1) * self.period

    def end_if_inside(self, t: float) -> float | None:
        """If time `t` [s since activation] falls in a window, that window's end; else None."""
        if t < self.start:
            return None
        offset = t - self.start
        if self.period is not None:
            offset %= self.period
        if offset < self.duration:
            return t - offset + self.duration
        return None


class LinkProfile(StrictModel):
    """Everything the link does to messages. GET/PUT /_link/profile speaks this."""

    uplink: Seconds = Field(0.0, description="[s] one-way delay, operator to robot")
    downlink: Seconds = Field(0.0, description="[s] one-way delay, robot to operator")
    jitter: Jitter = Field(default_factory=Jitter)
    loss: Loss = Field(default_factory=Loss)
    blackouts: list[Blackout] = Field(default_factory=list, max_length=100)
    schedule: Schedule | None = Field(
        None, description="contact windows, delay over time and per-window rates (null: always in contact)"
    )
    uplink_bytes_per_s: Rate | None = Field(
        None,
        description="[bytes/s] the uplink's rate: a message takes size / rate on the wire (null: unlimited)",
    )
    downlink_bytes_per_s: Rate | None = Field(
        None, description="[bytes/s] the downlink's rate (null: unlimited)"
    )
    reorder: bool = Field(
        False,
        description="let jitter reorder messages (off: release = max(arrival + delay, previous release))",
    )
    max_held_messages: Annotated[int, Field(ge=1, le=10_000_000)] = Field(
        100_000, description="per direction; beyond it `overflow` applies"
    )
    max_held_bytes: Annotated[int, Field(ge=1024, le=8 * 2**30)] = Field(
        256 * 2**20, description="[bytes] per direction"
    )
    overflow: Literal["drop_newest"] = Field(
        "drop_newest", description="what a full buffer does to new messages"
    )
    description: str = Field("", max_length=MAX_DESCRIPTION_CHARS, description="where the figures come from")

    def merged(self, update: dict[str, Any]) -> "LinkProfile":
        """This profile with the fields of a partial update (nested models replaced whole)."""
        return LinkProfile.model_validate({**self.model_dump(), **update})

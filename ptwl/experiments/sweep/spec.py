"""A trial's settings, the link it runs over, and the grid of trials a sweep runs."""

import random
from dataclasses import asdict, dataclass, field
from typing import Any

from latency.named import named_profile
from latency.profile import LinkProfile

OPERATORS = ("ground", "onboard")
BACKENDS = ("local", "ray")
# The fields that name a trial: a row of trials.csv with the same values is the same trial.
KEY_FIELDS = ("task", "operator", "autonomy", "rtt_s", "jitter_s", "loss", "seed")


@dataclass(frozen=True)
class TrialSpec:
    task: str
    operator: str  # ground: each behavior sent and waited for; onboard: one state_machine command
    rtt_s: float  # [s] round trip, split evenly uplink/downlink
    jitter_s: float  # [s] uniform +- jitter on every message's delay (order kept)
    loss: float  # chance a WebSocket message (an event) is lost; HTTP rides a reliable channel
    seed: int  # the scene's misalignments; with the trial's other settings, every random draw
    think_s: float = 2.0  # [s] an operator's mean think time between commands: uniform 0.5-1.5x
    profile: str | None = None  # a named link profile whose blackouts apply (its delays do not)
    max_age_s: float | None = None  # [s] every command's max_age (None: commands never expire)
    # The onboard machine's autonomy level (None: the command's default, `full`; the ground
    # operator has none), and a machine file run instead of the task's built-in one.
    autonomy: str | None = None
    machine: str | None = None

    @property
    def arm(self) -> str:
        return arm_of(self.operator, self.autonomy)

    def key(self) -> tuple[str, ...]:
        """As written in trials.csv (repr of floats: exact)."""
        return tuple(cell(getattr(self, name)) for name in KEY_FIELDS)

    def file_stem(self) -> str:
        """The trial's file name without suffix, from its key: lid_ground_rtt2.0_j0.0_l0.0_s3
        (an autonomy level after the operator: plug_onboard-low_rtt2.0_...)."""
        task, operator, autonomy, rtt, jitter, loss, seed = self.key()
        who = f"{operator}-{autonomy}" if autonomy else operator
        return f"{task}_{who}_rtt{rtt}_j{jitter}_l{loss}_s{seed}"

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)

    def rng(self, purpose: str) -> random.Random:
        """A generator for one purpose, the same for this seed at every RTT and for either
        operator (a paired design: only the delay differs between grid points)."""
        return random.Random(f"{purpose}:{self.task}:{self.seed}")

    def link_profile(self) -> LinkProfile:
        base = named_profile(self.profile) if self.profile else LinkProfile()
        draw = self.rng("link").randrange(2**32)
        # A named profile's jitter and loss apply with this trial's seed (else every trial of
        # the sweep would draw the same delays); --jitter and --loss replace them.
        jitter = (
            {"distribution": "uniform", "amount": self.jitter_s, "seed": draw}
            if self.jitter_s > 0.0
            else {**base.jitter.model_dump(), "seed": draw}
        )
        loss = (
            {"model": "bernoulli", "probability": self.loss, "seed": draw}
            if self.loss > 0.0
            else {**base.loss.model_dump(), "seed": draw}
        )
        return base.merged(
            {"uplink": self.rtt_s / 2.0, "downlink": self.rtt_s / 2.0, "jitter": jitter, "loss": loss}
        )


def _levels(autonomies: list[str] | None) -> list[str | None]:
    """The autonomy levels an operator runs at: those given, or None (the command's default)."""
    return list(autonomies) if autonomies else [None]


def arm_of(operator: str, autonomy: str | None) -> str:
    """Who runs the task, as reports group trials: ground, onboard, or onboard at a level."""
    return operator if not autonomy else f"{operator} ({autonomy})"


def cell(value: object) -> str:
    """How a value is written in the CSV: repr for floats (round-trips exactly)."""
    if isinstance(value, bool):
        return "1" if value else "0"
    if isinstance(value, float):
        return repr(value)
    return "" if value is None else str(value)


def grid(
    task: str,
    rtts_s: list[float],
    trials: int,
    operators: list[str],
    jitter_s: float,
    loss: float,
    seed: int,
    think_s: float,
    profile: str | None,
    max_age_s: float | None = None,
    autonomies: list[str] | None = None,
    machine: str | None = None,
) -> list[TrialSpec]:
    """Every trial, in the order the outputs list them: operator (onboard at each autonomy
    level given), RTT, then seed."""
    return [
        TrialSpec(
            task, operator, rtt, jitter_s, loss, seed + i, think_s, profile, max_age_s, autonomy, machine
        )
        for operator in operators
        for autonomy in _levels(autonomies if operator == "onboard" else None)
        for rtt in rtts_s
        for i in range(trials)
    ]


@dataclass
class SweepSettings:
    task: str
    rtts_s: list[float]
    trials: int
    operators: list[str]
    out: str
    jitter_s: float = 0.0
    loss: float = 0.0
    think_s: float = 2.0
    seed: int = 0
    profile: str | None = None
    max_age_s: float | None = None
    workers: int = 1
    backend: str = "local"
    ray_address: str | None = None
    record: bool = False  # one MCAP per trial in out/recordings (only the trials this run runs)
    autonomies: list[str] = field(default_factory=list)  # the onboard operator's levels (none: default)
    machine: str | None = None  # a machine file run instead of the task's built-in one
    argv: list[str] = field(default_factory=list)

    def specs(self) -> list[TrialSpec]:
        return grid(
            self.task,
            self.rtts_s,
            self.trials,
            self.operators,
            self.jitter_s,
            self.loss,
            self.seed,
            self.think_s,
            self.profile,
            self.max_age_s,
            self.autonomies,
            self.machine,
        )

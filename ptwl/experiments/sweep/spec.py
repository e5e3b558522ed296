"""A trial's settings, the link it runs over, and the grid of trials a sweep runs."""

import itertools
import math
import random
from dataclasses import asdict, dataclass, field
from functools import cache
from pathlib import Path
from typing import Any

from ptwl_config import PtwlError

from latency.named import named_profile
from latency.plan_file import read_schedule
from latency.profile import LinkProfile
from latency.schedule import Schedule

OPERATORS = ("ground", "onboard")
BACKENDS = ("local", "ray")
# The fields that name a trial: a row of trials.csv with the same values is the same trial.
KEY_FIELDS = ("task", "operator", "autonomy", "rtt_s", "jitter_s", "loss", "seed")
DEFAULT_RTTS_S = [0.0, 1.0, 2.0, 5.0, 10.0]
# Plan offsets are whole 1 ms ticks: the link's edges then fall on the ticks trials act on.
OFFSET_TICKS_PER_S = 1000


class RttSetBySchedule(PtwlError, ValueError):
    """RTTs asked for a link whose schedule's delay points set the delay."""


@cache
def schedule_file(path: str, ground_node: int = 1, robot_node: int = 2) -> Schedule:
    """A schedule file's Schedule (TOML or ION plan), read once per process: every trial asks."""
    return read_schedule(Path(path), ground_node, robot_node)


def link_schedule(
    profile: str | None, schedule: str | None, ground_node: int = 1, robot_node: int = 2
) -> Schedule | None:
    """The schedule a trial's link follows: the file's, else the named profile's (None: always
    in contact, at the RTT's delay)."""
    if schedule is not None:
        return schedule_file(schedule, ground_node, robot_node)
    return named_profile(profile).schedule if profile else None


def plan_span_s(schedule: Schedule | None) -> float:
    """[s] the stretch of a schedule a trial may start in: its period, else up to its last
    contact's end (0: no schedule, or always in contact)."""
    if schedule is None:
        return 0.0
    if schedule.period is not None:
        return schedule.period
    return max((c.end for c in schedule.contacts or []), default=0.0)


def fixed_rtt_s(schedule: Schedule | None) -> float | None:
    """[s] the round trip a schedule's delay points set: twice their mean one-way delay over
    the points' span (the piecewise-linear curve's time average; one instant: its points' mean).
    None: no points, the RTT sets the delay."""
    points = schedule.delay if schedule is not None else []
    if not points:
        return None
    span_s = points[-1].at - points[0].at
    if span_s == 0.0:
        return 2.0 * sum(p.one_way_s for p in points) / len(points)
    area = sum((b.at - a.at) * (a.one_way_s + b.one_way_s) / 2.0 for a, b in itertools.pairwise(points))
    return 2.0 * area / span_s


def default_rtts_s(schedule: Schedule | None) -> list[float]:
    """The RTTs a sweep runs when none are asked: the one a schedule's delay points set, or
    DEFAULT_RTTS_S."""
    fixed = fixed_rtt_s(schedule)
    return [fixed] if fixed is not None else list(DEFAULT_RTTS_S)


def can_lose_signal(profile: LinkProfile) -> bool:
    """Whether a link can close: contact windows or blackouts."""
    contacts = profile.schedule.contacts if profile.schedule is not None else None
    return contacts is not None or bool(profile.blackouts)


@dataclass(frozen=True)
class TrialSpec:
    task: str
    operator: str  # ground: each behavior sent and waited for; onboard: one state_machine command
    rtt_s: float  # [s] round trip, split evenly uplink/downlink
    jitter_s: float  # [s] uniform +- jitter on every message's delay (order kept)
    loss: float  # chance a WebSocket message (an event) is lost; HTTP rides a reliable channel
    seed: int  # the scene's misalignments; with the trial's other settings, every random draw
    think_s: float = 2.0  # [s] an operator's mean think time between commands: uniform 0.5-1.5x
    # A named link profile: its blackouts, schedule, rates, jitter and loss apply; its delays
    # do not (the RTT's do, unless its schedule has delay points).
    profile: str | None = None
    max_age_s: float | None = None  # [s] every command's max_age (None: commands never expire)
    # The onboard machine's autonomy level (None: the command's default, `full`; the ground
    # operator has none), and a machine file run instead of the task's built-in one.
    autonomy: str | None = None
    machine: str | None = None
    # A schedule file (TOML, or an ION contact plan between these nodes) replacing the profile's
    # schedule.
    schedule: str | None = None
    ground_node: int = 1
    robot_node: int = 2

    @property
    def arm(self) -> str:
        return arm_of(self.operator, self.autonomy)

    def link_schedule(self) -> Schedule | None:
        return link_schedule(self.profile, self.schedule, self.ground_node, self.robot_node)

    @property
    def plan_offset_s(self) -> float:
        """[s] how far into its schedule (and blackouts) the link is as the trial starts: a
        seeded draw, uniform over the schedule's period (or up to its last contact's end), in
        whole ticks; the same for this seed at every RTT and for either operator, so a pass's
        every phase is sampled and paired trials meet the same one."""
        span_s = plan_span_s(self.link_schedule())
        return math.floor(self.rng("plan").random() * span_s * OFFSET_TICKS_PER_S) / OFFSET_TICKS_PER_S

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
        update: dict[str, Any] = {
            "uplink": self.rtt_s / 2.0,
            "downlink": self.rtt_s / 2.0,
            "jitter": jitter,
            "loss": loss,
        }
        if self.schedule is not None:
            update["schedule"] = self.link_schedule()
        return base.merged(update)


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
    schedule: str | None = None,
    ground_node: int = 1,
    robot_node: int = 2,
) -> list[TrialSpec]:
    """Every trial, in the order the outputs list them: operator (onboard at each autonomy
    level given), RTT, then seed."""
    return [
        TrialSpec(
            task,
            operator,
            rtt,
            jitter_s,
            loss,
            seed + i,
            think_s,
            profile,
            max_age_s,
            autonomy,
            machine,
            schedule,
            ground_node,
            robot_node,
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
    schedule: str | None = None  # a schedule file replacing the profile's schedule
    ground_node: int = 1  # an ION plan's nodes: uplink ground -> robot, downlink back
    robot_node: int = 2
    argv: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        # Delay points set the delay: the RTTs would name delays the trials never had.
        fixed = fixed_rtt_s(self.link_schedule())
        if fixed is not None and self.rtts_s != [fixed]:
            source = f"--schedule {self.schedule}" if self.schedule else f"--profile {self.profile}"
            raise RttSetBySchedule(
                f"--rtt {','.join(f'{r:g}' for r in self.rtts_s)} and {source}: its schedule's delay points "
                f"set the delay (RTT {fixed:.6g} s, twice their mean one-way delay); leave out --rtt"
            )

    def link_schedule(self) -> Schedule | None:
        return link_schedule(self.profile, self.schedule, self.ground_node, self.robot_node)

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
            self.schedule,
            self.ground_node,
            self.robot_node,
        )

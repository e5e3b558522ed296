"""`ptwl sweep`: a task at several round trips, ground-operated vs onboard, in virtual time.

ptwl sweep --task lid --rtt 0,1,2,5,10 --trials 20 --operator ground,onboard --out runs/lid
ptwl sweep --task lid --profile lunar_far_side_relay --trials 20 --out runs/lid-relay
ptwl sweep --task lid --schedule pass.ionrc --ground-node 1 --robot-node 2 --out runs/lid-ion
(no --rtt with a schedule whose delay points, an ION plan's ranges, set the delay)
"""

import argparse
import os
import sys
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any, NoReturn

from ptwl_config import PtwlError

from latency.named import named_profiles
from latency.plan_file import PlanFileError
from latency.profile import MAX_DELAY_S
from ptwl.experiments.sweep.spec import (
    BACKENDS,
    DEFAULT_RTTS_S,
    OPERATORS,
    RttSetBySchedule,
    SweepSettings,
    default_rtts_s,
    link_schedule,
)
from robot_sim.machines.library import builtin_machines
from robot_sim.machines.spec import AUTONOMY_LEVELS
from robot_sim.params import MAX_AGE_S
from robot_sim.policies import POLICIES


def _floats(text: str) -> list[float]:
    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"a comma-separated list of seconds, got {text!r}") from None
    if not values or any(not 0.0 <= v <= MAX_DELAY_S for v in values):
        raise argparse.ArgumentTypeError(f"each RTT must be in [0, {MAX_DELAY_S:g}] s, got {text!r}")
    return sorted(set(values))


def _operators(text: str) -> list[str]:
    names = [v.strip() for v in text.split(",") if v.strip()]
    if not names or any(n not in OPERATORS for n in names):
        raise argparse.ArgumentTypeError(f"operators from {', '.join(OPERATORS)}, got {text!r}")
    return list(dict.fromkeys(names))


def _ranged(kind: type, lo: float, hi: float, unit: str = "") -> Callable[[str], Any]:
    def parse(text: str) -> float:
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"a number, got {text!r}") from None
        if not lo <= value <= hi:
            raise argparse.ArgumentTypeError(f"must be in [{lo:g}, {hi:g}]{unit}, got {text}")
        return value

    return parse


def _autonomies(text: str) -> list[str]:
    names = [v.strip() for v in text.split(",") if v.strip()]
    if not names or any(n not in AUTONOMY_LEVELS for n in names):
        raise argparse.ArgumentTypeError(f"levels from {', '.join(AUTONOMY_LEVELS)}, got {text!r}")
    return list(dict.fromkeys(names))


def _machine_task(args: argparse.Namespace) -> str:
    """The task (scene) a sweep runs: --task, or the --machine file's own; the file is read and
    validated here, once, so a bad one is one line and exit 2 before any trial runs."""
    from robot_sim.machines.library import read_machine

    if args.machine is None:
        if args.task is None:
            raise SystemExit("ptwl sweep: give --task NAME or --machine FILE")
        if args.autonomy and builtin_machines().get(args.task) is None:
            raise SystemExit(
                f"ptwl sweep: --autonomy: the {args.task} machine is Python (its decisions have no levels)"
            )
        return str(args.task)
    try:
        spec = read_machine(Path(args.machine))
    except (OSError, PtwlError) as err:
        raise SystemExit(f"ptwl sweep: --machine: {err}") from None
    task = args.task or spec.task
    if task is None or task not in POLICIES or (spec.task and spec.task != task):
        raise SystemExit(
            f"ptwl sweep: --machine {args.machine}: its `task` ({spec.task}) must name the scene, one of "
            f"{', '.join(POLICIES)} (and agree with --task)"
        )
    return task


def settings_from(
    args: argparse.Namespace, argv: list[str], error: Callable[[str], NoReturn]
) -> SweepSettings:
    """The sweep's settings; an argument they refuse (a bad schedule file, --rtt with a
    schedule whose delay points set the delay) goes to `error` (argparse's: usage, exit 2)."""
    task = _machine_task(args)
    schedule = str(Path(args.schedule).resolve()) if args.schedule else None
    try:
        # Read here, once, so a bad file is one line naming its line before any trial runs.
        rtts_s = args.rtt or default_rtts_s(
            link_schedule(args.profile, schedule, args.ground_node, args.robot_node)
        )
        return _settings(args, argv, task, rtts_s, schedule)
    except PlanFileError as err:
        error(f"argument --schedule: {err}")
    except RttSetBySchedule as err:
        error(str(err))


def _settings(
    args: argparse.Namespace, argv: list[str], task: str, rtts_s: list[float], schedule: str | None
) -> SweepSettings:
    return SweepSettings(
        task=task,
        rtts_s=rtts_s,
        trials=args.trials,
        operators=args.operator,
        out=args.out,
        jitter_s=args.jitter,
        loss=args.loss,
        think_s=args.think,
        seed=args.seed,
        profile=args.profile,
        max_age_s=args.max_age,
        workers=args.workers,
        backend=args.backend,
        ray_address=args.ray_address,
        record=args.record,
        autonomies=args.autonomy or [],
        machine=str(Path(args.machine).resolve()) if args.machine else None,
        schedule=schedule,
        ground_node=args.ground_node,
        robot_node=args.robot_node,
        argv=argv,
    )


def cmd_sweep(args: argparse.Namespace, error: Callable[[str], NoReturn]) -> int:
    # Imported here: matplotlib and the sweep machinery would add ~0.8 s to every `ptwl` start.
    from ptwl.experiments.sweep.backends import BackendMissing
    from ptwl.experiments.sweep.plots import findings
    from ptwl.experiments.sweep.sweep import run_sweep

    settings = settings_from(args, sys.argv[1:], error)
    if args.realtime:
        return realtime(settings)
    try:
        rows = run_sweep(settings)
    except BackendMissing as err:
        print(f"ptwl sweep: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(
            f"\nptwl sweep: interrupted; finished trials are in {args.out}/trials.csv; "
            "run the same command to resume",
            file=sys.stderr,
        )
        return 130
    print(f"ptwl sweep: {len(rows)} trials in {args.out} (report.md, summary.md, trials.csv)")
    for line in findings(rows):
        print(line)
    return 0


def add_sweep_parser(sub: "argparse._SubParsersAction[argparse.ArgumentParser]") -> None:
    sweep = sub.add_parser(
        "sweep", help="latency sweep: a task at several RTTs, ground-operated vs onboard, in virtual time"
    )
    sweep.add_argument(
        "--task", choices=list(POLICIES), help="the task's built-in machine (or give --machine)"
    )
    sweep.add_argument(
        "--machine", help="a machine file (TOML, README: Machines) run instead; its task names the scene"
    )
    sweep.add_argument(
        "--autonomy",
        type=_autonomies,
        default=None,
        help="the onboard machine at each of these levels (off,low,high,full): a transition whose level is "
        "not below it waits for the ground operator, who confirms after a think time across the link",
    )
    sweep.add_argument(
        "--rtt",
        type=_floats,
        default=None,
        help=f"[s] e.g. {','.join(f'{r:g}' for r in DEFAULT_RTTS_S)} (the default); refused with a schedule "
        "whose delay points set the delay (its RTT is then twice their mean one-way delay)",
    )
    sweep.add_argument("--trials", type=_ranged(int, 1, 100_000), default=10, help="trials per grid point")
    sweep.add_argument("--operator", type=_operators, default=list(OPERATORS), help="ground,onboard")
    sweep.add_argument("--out", required=True, help="directory for trials.csv, summary, report (resumable)")
    sweep.add_argument("--jitter", type=_ranged(float, 0.0, 60.0, " s"), default=0.0, help="[s] uniform +-")
    sweep.add_argument("--loss", type=_ranged(float, 0.0, 0.9), default=0.0, help="chance an event is lost")
    sweep.add_argument(
        "--think", type=_ranged(float, 0.0, 600.0, " s"), default=2.0, help="[s] mean think time (0.5-1.5x)"
    )
    sweep.add_argument("--seed", type=_ranged(int, 0, 2**31 - 1), default=0, help="first scene seed")
    sweep.add_argument(
        "--profile",
        choices=sorted(named_profiles()),
        default=None,
        help="a named link whose blackouts, schedule, rates, jitter and loss apply (the RTT replaces its "
        "delays, unless its schedule has delay points); each trial starts at a seeded point of its schedule",
    )
    sweep.add_argument(
        "--schedule",
        metavar="FILE",
        default=None,
        help="a schedule file (.toml: a Schedule table; else an ION contact plan) replacing the profile's",
    )
    sweep.add_argument(
        "--ground-node",
        type=_ranged(int, 1, 2**63 - 1),
        default=1,
        help="an ION plan's ground node (uplink from)",
    )
    sweep.add_argument(
        "--robot-node",
        type=_ranged(int, 1, 2**63 - 1),
        default=2,
        help="an ION plan's robot node (downlink from)",
    )
    sweep.add_argument(
        "--max-age",
        type=_ranged(float, 0.001, MAX_AGE_S, " s"),  # from one control tick to the API's bound
        default=None,
        help="[s] every command's max_age (stamped sent_at): one older when it would start expires, "
        "and the operator sends it again; default: commands never expire",
    )
    sweep.add_argument("--workers", type=_ranged(int, 1, 1024), default=os.cpu_count() or 1)
    sweep.add_argument("--backend", choices=BACKENDS, default="local")
    sweep.add_argument("--ray-address", default=None, help="an existing Ray cluster (default: RAY_ADDRESS)")
    sweep.add_argument(
        "--record",
        action="store_true",
        help="one MCAP per trial in OUT/recordings (ptwl report/replay read it)",
    )
    sweep.add_argument(
        "--realtime",
        action="store_true",
        help="one grid point through the real `ptwl serve` and `ptwl proxy`, against virtual time",
    )
    sweep.set_defaults(func=partial(cmd_sweep, error=sweep.error))


def realtime(settings: SweepSettings) -> int:
    """--realtime: the grid point through a real robot and link, against virtual time."""
    from ptwl.experiments.sweep.realtime import NotOneGridPoint, cross_check, link_delays
    from ptwl.launcher import running_proxy, running_server

    try:
        delays = link_delays(settings)
    except NotOneGridPoint as err:
        print(f"ptwl sweep: {err}", file=sys.stderr)
        return 2
    with (
        running_server("--scene", settings.task) as robot,
        running_proxy(robot.url, *delays) as link,
    ):
        return cross_check(settings, robot.url, link.url)

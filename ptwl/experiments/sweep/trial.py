"""One trial in virtual time: the robot, both directions of the link and the operator on one
simulated clock (the robot's sim time), as fast as the CPU allows; no sleeping, no sockets.

Per control tick (1 ms), skipping straight to the next tick where any of these has work:
    the link releases what is due, in time order: requests into the robot's inbox, replies and
        events to the operator, who reacts at once (its next request enters the link then)
    the operator acts on its own deadlines (a think time over, a report overdue)
    the robot answers its inbox (the server does so between 2 ms batches), starts a queued
        command if idle, and steps; a command that ended goes down as an event

The ground's own instants are kept to the tick (1 ms). Every draw (scene, think times, jitter,
loss) comes from the trial's settings, so a trial gives the same row on any worker.
"""

import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

from latency.clock import SimulatedLink
from latency.delay_line import DIRECTIONS, DirectionModel, Dropped
from latency.outlook import is_open, next_change
from latency.profile import LinkProfile
from ptwl.experiments.sweep.operators import Operator, operator_for
from ptwl.experiments.sweep.recorder import TrialRecorder
from ptwl.experiments.sweep.robot import VIRTUAL_EPOCH_S, Event, Reply, Request, VirtualRobot
from ptwl.experiments.sweep.spec import TrialSpec, plan_span_s
from robot_sim.policies.run import trial_metrics

MAX_TRIAL_S = 3600.0  # [s] of virtual time: a trial still going has lost its way
REQUEST_BYTES = 400  # a command's JSON, about
EVENT_BYTES = 1500  # a command event or status with its report, about


def max_trial_s(spec: TrialSpec) -> float:
    """[s] of virtual time a trial may run: MAX_TRIAL_S, and one whole cycle of its schedule on
    top (a trial may start as a long gap begins: the lunar relay's lasts 95 min)."""
    return MAX_TRIAL_S + plan_span_s(spec.link_schedule())


def blackout_s(profile: LinkProfile, until_s: float, plan_offset_s: float = 0.0) -> float:
    """[s] of the trial's [0, until_s] inside the profile's blackout windows (timed from the
    plan's start, `plan_offset_s` before the trial's)."""
    lo, hi = plan_offset_s, plan_offset_s + until_s
    total = 0.0
    for window in profile.blackouts:
        start = window.start
        if window.period is not None and start < lo:  # skip the repeats that ended before the trial
            start += math.floor((lo - start) / window.period) * window.period
        while start < hi:
            total += max(0.0, min(start + window.duration, hi) - max(start, lo))
            if window.period is None:
                break
            start += window.period
    return total


def los_s(profile: LinkProfile, until_s: float, plan_offset_s: float = 0.0) -> float:
    """[s] of the trial's [0, until_s] in which either direction was closed (a contact gap or a
    blackout): the closed stretches between the link's edges, walked edge to edge, exact."""
    models = [DirectionModel(profile, d, 1, -plan_offset_s) for d in DIRECTIONS]
    t, total = 0.0, 0.0
    while t < until_s:
        # Either direction's next edge; none ahead (next_change: None) means no change to come.
        edges = [e for m in models if (e := next_change(m, t)) is not None]
        until = min([*edges, until_s])
        if not all(is_open(m, t) for m in models):
            total += until - t
        t = until
    return total


@dataclass
class Trial:
    """A finished trial: the robot as it ended, the operator, the link it ran over."""

    spec: TrialSpec
    robot: VirtualRobot
    operator: Operator
    profile: LinkProfile
    lost: int  # messages the link lost


def quiet_until(link: SimulatedLink, operator: Operator, limit_s: float = MAX_TRIAL_S) -> float:
    """[s] the next instant anything but the robot acts: a message due out of the link, or the
    operator's own deadline; until then the loop below would only tick the robot. Once the
    operator has finished, the loop ends after its tick."""
    if operator.finished:
        return 0.0
    instants = [t for t in (link.next_release(), operator.wake_at) if t is not None]
    return min(instants, default=limit_s)


def simulate(spec: TrialSpec, profile: LinkProfile | None = None, record: Path | None = None) -> Trial:
    """Run the trial to its end (the operator knows the outcome) or max_trial_s; `profile`
    replaces the spec's link (tests give blackouts at chosen times); `record` an MCAP file to
    record it into."""
    robot = VirtualRobot(spec.task, spec.seed)
    sim = robot.sim
    profile = profile or spec.link_profile()
    link = SimulatedLink(profile, plan_offset_s=spec.plan_offset_s)
    recorder = TrialRecorder(record, spec, robot, link) if record is not None else None
    operator = operator_for(spec, VIRTUAL_EPOCH_S)
    inbox: list[Request] = []
    lost = [0]
    limit_s = max_trial_s(spec)

    def admit(direction: str, size: int, kind: str, deliver: Callable[[], object], lossy: bool) -> None:
        if isinstance(link.link.admit(direction, size, kind, deliver, lossy), Dropped):
            lost[0] += 1

    def up(requests: list[Request]) -> None:
        for request in requests:  # HTTP: a reliable channel, lost only in a `drop` blackout
            admit("uplink", REQUEST_BYTES, "http", partial(inbox.append, request), lossy=False)

    def down(message: Reply | Event) -> None:
        def deliver() -> None:
            up(operator.on_message(link.clock.now, message))

        lossy = isinstance(message, Event)  # an event on the telemetry socket; a reply is HTTP
        admit("downlink", EVENT_BYTES, "ws" if lossy else "http", deliver, lossy)

    up(operator.begin(0.0, sim.state().port))
    while not operator.finished and sim.time < limit_s:
        now = sim.time
        link.advance_to(now)
        while (wake := operator.wake_at) is not None and wake <= now:
            up(operator.on_wake(now))
        for request in inbox:
            down(robot.handle(request))
        inbox.clear()
        if recorder is not None:
            done = robot.tick()
            recorder.observe()
        else:
            done = robot.tick_until(quiet_until(link, operator, limit_s))
        if done is not None:
            link.advance_to(sim.time)
            down(done)
    if recorder is not None:
        recorder.close()
    return Trial(spec, robot, operator, profile, lost[0])


def run_trial(spec: TrialSpec, record_dir: str | None = None) -> dict[str, Any]:
    """The trial's row of trials.csv (table.COLUMNS); with `record_dir`, its MCAP there too."""
    record = Path(record_dir) / f"{spec.file_stem()}.mcap" if record_dir is not None else None
    return row(simulate(spec, record=record))


def row(trial: Trial) -> dict[str, Any]:
    spec, robot, operator, sim = trial.spec, trial.robot, trial.operator, trial.robot.sim
    figures = robot.figures
    first, last = figures.first_start_s, robot.last_end_s
    verdict = sim.task()
    finished_at = operator.finished_at_s if operator.finished_at_s is not None else sim.time
    metrics = trial_metrics(figures.steps)
    offset_s = spec.plan_offset_s
    closed_s = los_s(trial.profile, finished_at, offset_s)
    return {
        **spec.as_dict(),
        "plan_offset_s": offset_s,
        "success": verdict.success,
        "progress": verdict.progress,
        "end": operator.end or "timed_out",
        "why": operator.why or f"no outcome after {max_trial_s(spec):g} s",
        "task_time_s": last - first if first is not None and last is not None else 0.0,
        "operator_time_s": finished_at,
        "commands_sent": operator.commands_sent,
        "wait_cycles": operator.wait_cycles,
        "requeries": operator.requeries,
        "unstarted": operator.unstarted,
        "decisions_waited": robot.decisions_waited,
        "decision_wait_s": robot.decision_wait_s,
        "think_total_s": operator.think_s,
        "max_force_n": metrics["max_force_n"],
        "mean_force_n": figures.mean_force_n(),
        "max_torque_nm": metrics["max_torque_nm"],
        "mean_torque_nm": figures.mean_torque_nm(),
        "behaviors": metrics["behaviors"],
        "rwe": metrics["rwe"],
        "dither": metrics["dither"],
        "gripper": metrics["gripper"],
        **{f"ptwl_{exit_name}": count for exit_name, count in metrics["ptwl"].items()},
        "lost_messages": trial.lost,
        "blackout_s": blackout_s(trial.profile, finished_at, offset_s),
        "los_s": closed_s,
        "los_in_trial": closed_s > 0.0,
    }

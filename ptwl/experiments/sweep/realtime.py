"""`ptwl sweep --realtime`: one grid point through the real `ptwl serve` and `ptwl proxy`, paced
to real time, with the same operators as the virtual-time trials, against their result.

The operator objects are the same (operators.py); only what carries their requests changes:
HTTP through the proxy (POST with the tag as `x-ptwl-sender`, GET by id) and the telemetry
socket through the proxy for command events. The task time is read from the robot's own
records (first command's start to last one's end, Unix time).
"""

import queue
import statistics
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import httpx
from ptwl_config import PtwlError

from ptwl.experiments.sweep.operators import Operator, operator_for
from ptwl.experiments.sweep.robot import Accepted, Done, Outcome, Post, Request, Status
from ptwl.experiments.sweep.spec import SweepSettings, TrialSpec
from ptwl.experiments.sweep.trial import MAX_TRIAL_S, run_trial
from robot_sim.behaviors import Pose
from robot_sim.finite import number_or_nan, report_from_json
from server.client import RobotClient, RobotError

AGREEMENT = 0.05  # the real mean task time within 5 % of the virtual one


def outcome_of(event: dict[str, Any]) -> Outcome:
    """How a command ended, from its status or `done` event: with a BehaviorReport (the fields a
    policy reads) if it ran, none if it never started (expired, dropped)."""
    ran = event.get("started_at") is not None
    report = report_from_json(event, 0.0, number_or_nan(event["duration"])) if ran else None
    return Outcome(str(event["exit"]), str(event.get("detail") or ""), report)


class LinkedOperator:
    """Carries one operator's requests over the real link, and what comes back to it."""

    def __init__(self, link_url: str, prefix: str) -> None:
        self.client = RobotClient(link_url)
        self.prefix = prefix
        self.inbox: queue.SimpleQueue[Accepted | Status | Done] = queue.SimpleQueue()
        self.ids: dict[str, int] = {}
        self._pool = ThreadPoolExecutor(max_workers=4)  # a request takes a round trip
        self._listener = threading.Thread(target=self._listen, name="sweep-link-listener", daemon=True)
        self._listener.start()

    def _listen(self) -> None:
        try:
            for message in self.client.telemetry():
                sender = message.get("sender") or ""
                if (
                    message["type"] == "command"
                    and message["status"] == "done"
                    and sender.startswith(self.prefix)
                ):
                    self.inbox.put(Done(sender.removeprefix(self.prefix), outcome_of(message)))
        except Exception:  # the link closed at the end of the run: nothing more to hear
            return

    def send(self, requests: list[Request]) -> None:
        for request in requests:
            self._pool.submit(self._carry, request)

    def _carry(self, request: Request) -> None:
        try:
            if isinstance(request, Post):
                params = request.params.model_dump()
                kind = params.pop("type")
                accepted = self.client.command(kind, sender=self.prefix + request.tag, **params)
                self.ids[request.tag] = accepted.id
                self.inbox.put(Accepted(request.tag))
                return
            status = self._status(request.tag)
            outcome = outcome_of(status) if status is not None and status["status"] == "done" else None
            self.inbox.put(Status(request.tag, status is not None, outcome))
        except (httpx.HTTPError, RobotError):
            return  # lost: the operator asks again once its patience runs out

    def _status(self, tag: str) -> dict[str, Any] | None:
        if tag in self.ids:
            return self.client.get(self.ids[tag]).model_dump()
        mine = [c for c in self.client.commands(limit=64) if c.sender == self.prefix + tag]
        return mine[-1].model_dump() if mine else None

    def close(self) -> None:
        self._pool.shutdown(wait=True)
        self.client.close()  # ends the telemetry socket, and with it the listener
        self._listener.join(timeout=5.0)


def run_real(spec: TrialSpec, robot_url: str, link_url: str) -> dict[str, Any]:
    """One trial on the real system; its task time from the robot's records."""
    with RobotClient(robot_url) as direct:
        direct.reset_scene(spec.task, spec.seed)
        port = direct.state().port
    prefix = f"rt{spec.seed}-{time.time_ns()}-"
    carrier = LinkedOperator(link_url, prefix)
    time.sleep(0.3 + spec.rtt_s / 2.0)  # the telemetry socket is open before the first send
    t0, epoch_s = time.monotonic(), time.time()  # the operator's t = 0, and as Unix time
    operator: Operator = operator_for(spec, epoch_s)

    def now() -> float:
        return time.monotonic() - t0

    carrier.send(operator.begin(0.0, Pose.of(port.position, port.quaternion)))
    while not operator.finished and now() < MAX_TRIAL_S:
        wake = operator.wake_at
        wait = 0.5 if wake is None else min(0.5, max(0.0, wake - now()))
        try:
            message = carrier.inbox.get(timeout=wait)
        except queue.Empty:
            message = None
        if message is not None:  # stamped when it arrived, not when the wait began
            carrier.send(operator.on_message(now(), message))
        while (wake := operator.wake_at) is not None and wake <= now():
            carrier.send(operator.on_wake(now()))
    carrier.close()
    with RobotClient(robot_url) as direct:
        records = [c for c in direct.commands(limit=100) if (c.sender or "").startswith(prefix)]
        success = direct.task().success
    ran = [c for c in records if c.started_at is not None]  # an expired command never started
    starts = [c.started_at for c in ran if c.started_at is not None]
    ends = [c.ended_at for c in ran if c.ended_at is not None]
    return {
        "seed": spec.seed,
        "success": success,
        "end": operator.end,
        "task_time_s": max(ends) - min(starts),
        "robot_lag_s": max(0.0, sum(robot_lag_s(c.started_at, c.ended_at, c.duration) for c in ran)),
        "operator_time_s": operator.finished_at_s,
    }


def robot_lag_s(started_at: float | None, ended_at: float | None, duration_s: float | None) -> float:
    """[s] how far the robot's simulation fell behind the wall clock during a command: its
    wall-clock span (Unix times the robot stamps) less the simulated time it ran (`duration`);
    negative where it caught up a lag from before. A trial's sum says how much of its task time
    the robot itself (its host, or its own loop) added: not the link's, not the operator's."""
    if started_at is None or ended_at is None or duration_s is None:
        return 0.0
    return (ended_at - started_at) - duration_s


class NotOneGridPoint(PtwlError, ValueError):
    """The real-time cross-check runs one grid point on a plain link."""


def link_delays(settings: SweepSettings) -> list[str]:
    """The proxy's arguments for the grid point: its round trip split evenly; NotOneGridPoint if
    the settings name more than one point or a link that is not plain."""
    if len(settings.rtts_s) != 1 or len(settings.operators) != 1:
        raise NotOneGridPoint("--realtime runs one grid point: give one --rtt and one --operator")
    if (
        settings.jitter_s
        or settings.loss
        or settings.profile
        or settings.schedule
        or settings.max_age_s is not None
    ):
        raise NotOneGridPoint(
            "--realtime runs a plain link: leave out --jitter, --loss, --profile, --schedule and --max-age"
        )
    half = f"{settings.rtts_s[0] / 2.0:g}"
    return ["--uplink", half, "--downlink", half]


def cross_check(settings: SweepSettings, robot_url: str, link_url: str, out: Any = sys.stdout) -> int:
    """Run the grid point in real time, on a robot (`ptwl serve`, scene settings.task) behind a
    link delaying as link_delays(settings) says, and in virtual time; 0 if the mean task times
    agree. The caller starts both (ptwl sweep --realtime: ptwl/launcher.py)."""
    specs = settings.specs()
    link_delays(settings)
    real = []
    for spec in specs:
        real.append(run_real(spec, robot_url, link_url))
        print(
            f"real time: seed {spec.seed}: task time {real[-1]['task_time_s']:.2f} s "
            f"(the robot's simulation {real[-1]['robot_lag_s']:.2f} s behind the wall clock)",
            file=out,
        )
    virtual = [run_trial(spec) for spec in specs]
    mean_real = statistics.fmean(r["task_time_s"] for r in real)
    mean_lag = statistics.fmean(r["robot_lag_s"] for r in real)
    mean_virtual = statistics.fmean(r["task_time_s"] for r in virtual)
    # Judged on the wall clock, lag and all: the lag is said so that a run that fails can be
    # told from a robot (or its host) that could not keep real time.
    difference = (mean_real - mean_virtual) / mean_virtual
    print(
        f"{settings.task}, {settings.operators[0]}, RTT {settings.rtts_s[0]:g} s, {len(specs)} trials: "
        f"mean task time {mean_real:.2f} s in real time (the robot {mean_lag:.2f} s behind it), "
        f"{mean_virtual:.2f} s in virtual time "
        f"({100.0 * difference:+.1f} %; agreement within {100.0 * AGREEMENT:.0f} % "
        f"{'holds' if abs(difference) <= AGREEMENT else 'FAILS'})",
        file=out,
    )
    return 0 if abs(difference) <= AGREEMENT else 1

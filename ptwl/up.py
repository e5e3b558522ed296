"""`ptwl up`: robot server, link proxy and console as three processes on 127.0.0.1.

Each is its own `ptwl` subprocess, so no package imports another to launch it. Ctrl-C (or
SIGTERM) stops all three. If one dies it is restarted on the same port and the restart is reported
(the others carry on: the console reconnects through the link, the robot keeps running); one that
keeps dying (`RestartBudget`) stops everything, and the exit names it.
"""

import signal
import sys
import threading
import time
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path

from ptwl.launcher import ServiceProcess, start

POLL_S = 0.2
MAX_RESTARTS = 3  # within RESTART_WINDOW_S, then give up
RESTART_WINDOW_S = 60.0


@dataclass
class RestartBudget:
    """At most `limit` restarts within `window_s`: a child that crashes on start is not restarted
    forever."""

    limit: int = MAX_RESTARTS
    window_s: float = RESTART_WINDOW_S
    _times: deque[float] = field(default_factory=deque)

    def allow(self, now: float) -> bool:
        while self._times and now - self._times[0] > self.window_s:
            self._times.popleft()
        if len(self._times) >= self.limit:
            return False
        self._times.append(now)
        return True


@dataclass
class Child:
    name: str
    args: tuple[str, ...]
    health: str
    echo: str
    startup_timeout: float = 30.0
    process: ServiceProcess | None = None
    budget: RestartBudget = field(default_factory=RestartBudget)
    restarts: int = 0

    def start(self) -> ServiceProcess:
        self.process = start(
            *self.args, health=self.health, startup_timeout=self.startup_timeout, echo=self.echo
        )
        return self.process

    def stop(self) -> None:
        if self.process is not None:
            self.process.stop()


def up(
    scene: str,
    link_args: list[str],
    server_port: int = 8000,
    proxy_port: int = 8001,
    console_port: int = 8080,
    record: Path | None = None,
) -> int:
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda signum, frame: stop.set())
    robot_url, link_url = f"http://127.0.0.1:{server_port}", f"http://127.0.0.1:{proxy_port}"
    serve_args = ("serve", "--port", str(server_port), "--scene", scene)
    proxy_args = ("proxy", "--upstream", robot_url, "--port", str(proxy_port), *link_args)
    link_file = link_record(record) if record is not None else None
    children = [
        Child("robot server", (*serve_args, *_record_args(record, 0)), "/api/health", "[robot] "),
        Child(
            "link proxy",
            (*proxy_args, *_record_args(link_file, 0)),
            "/_link/profile",
            "[link]  ",
        ),
        Child(
            "console",
            ("console", "--robot", link_url, "--port", str(console_port)),
            "/",
            "[console] ",
            startup_timeout=120.0,
        ),
    ]
    try:
        try:
            for child in children:
                child.start()
        except RuntimeError as err:
            print(f"ptwl up: a process did not start: {err}", file=sys.stderr, flush=True)
            return 1
        console = children[2].process
        assert console is not None
        print(f"ptwl up: open {console.url} (Ctrl-C stops all three)", flush=True)
        while not stop.wait(POLL_S):
            for child in children:
                assert child.process is not None
                code = child.process.process.poll()
                if code is None:
                    continue
                if not child.budget.allow(time.monotonic()):
                    print(
                        f"ptwl up: the {child.name} exited with code {code} for the {child.restarts + 1}th "
                        f"time in {RESTART_WINDOW_S:g} s; stopping the others",
                        file=sys.stderr,
                        flush=True,
                    )
                    return 1
                child.restarts += 1
                if child is children[0]:  # a restart records into a file of its own
                    child.args = (*serve_args, *_record_args(record, child.restarts))
                elif child is children[1]:
                    child.args = (*proxy_args, *_record_args(link_file, child.restarts))
                print(
                    f"ptwl up: the {child.name} exited with code {code}; restarting it "
                    f"(restart {child.restarts})",
                    file=sys.stderr,
                    flush=True,
                )
                try:
                    child.start()
                except RuntimeError as err:
                    print(f"ptwl up: the {child.name} did not restart: {err}", file=sys.stderr, flush=True)
                    return 1
                print(f"ptwl up: the {child.name} is back on {child.process.url}", flush=True)
        print("ptwl up: stopping", flush=True)
        return 0
    finally:
        for child in reversed(children):
            child.stop()


def link_record(record: Path) -> Path:
    """`ptwl up --record S.mcap`: the link's per-message delays go to S.link.mcap."""
    return record.with_suffix(".link.mcap")


def _record_args(record: Path | None, restarts: int) -> tuple[str, ...]:
    """A child's recording: S.mcap, then S.restart1.mcap, ... after restarts (never overwritten)."""
    if record is None:
        return ()
    return ("--record", str(record if restarts == 0 else record.with_suffix(f".restart{restarts}.mcap")))

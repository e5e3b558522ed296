"""Run `ptwl serve` as a real subprocess on an ephemeral port (tests, benchmarks, `ptwl up`)."""

import os
import re
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import IO, Any, Protocol

import httpx

from ptwl.guard.client import http_client

URL_PATTERN = re.compile(r" on (http://\S+)")
# The module each command starts from: a command with an entry point of its own imports only what
# it needs (the link: 0.7 s of CPU instead of 1.6 s per start); the rest go through `ptwl.cli`.
ENTRY_POINTS = {"proxy": "ptwl.proxy_cli"}


class ChildProcess(Protocol):
    """What the launcher and its callers use of a started service: `subprocess.Popen`'s part."""

    pid: int
    returncode: int | None
    stdout: IO[str] | None

    @property
    def args(self) -> Any: ...  # the command line it was started with
    def poll(self) -> int | None: ...
    def wait(self, timeout: float | None = None) -> int: ...
    def send_signal(self, sig: int) -> None: ...
    def kill(self) -> None: ...


def popen(module: str, args: list[str], env: dict[str, str]) -> ChildProcess:
    """`python -m MODULE ARGS`, its output (stdout and stderr) on one text pipe."""
    # Own process group: a terminal's Ctrl-C (sent to the whole foreground group) reaches only the
    # parent, which then stops each child once; a second signal would make uvicorn force-exit.
    return subprocess.Popen(
        [sys.executable, "-m", module, *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env=env,
        process_group=0,
    )


# How `start` makes a child: a fresh interpreter. The test suite puts a fork of a preloaded one here
# (tests/zygote.py), which starts the same main with the same argv, environment and process group.
SPAWN: Callable[[str, list[str], dict[str, str]], ChildProcess] = popen


def free_port() -> int:
    """A port nothing listens on right now (for children that cannot take port 0)."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


@dataclass
class ServiceProcess:
    url: str
    process: ChildProcess
    output: list[str]
    pump: threading.Thread | None = None  # reads its output; ends when the child does

    @property
    def port(self) -> int:
        return int(self.url.rsplit(":", 1)[1])

    def stop(self, sig: int = signal.SIGINT, timeout: float = 15.0) -> int:
        code = _stop(self.process, sig, timeout)
        if self.pump is not None:
            self.pump.join(timeout=5.0)  # the child's output has ended with it
        return code


@contextmanager
def running_server(*args: str, port: int = 0, startup_timeout: float = 30.0) -> Iterator[ServiceProcess]:
    """Start `ptwl serve --port PORT ARGS` (0: any free port), wait until healthy, SIGINT it after."""
    with running(
        "serve", "--port", str(port), *args, health="/api/health", startup_timeout=startup_timeout
    ) as p:
        yield p


@contextmanager
def running_proxy(
    upstream: str, *args: str, port: int = 0, startup_timeout: float = 30.0
) -> Iterator[ServiceProcess]:
    """Start `ptwl proxy --upstream URL --port PORT ARGS`, wait until it answers, SIGINT it after."""
    cmd = ("proxy", "--upstream", upstream, "--port", str(port), *args)
    with running(*cmd, health="/_link/profile", startup_timeout=startup_timeout) as p:
        yield p


@contextmanager
def running_console(robot_url: str, *args: str, startup_timeout: float = 60.0) -> Iterator[ServiceProcess]:
    """Start `ptwl console --robot URL` on a port the kernel picks, wait until it serves its page."""
    cmd = ("console", "--robot", robot_url, "--port", "0", *args)
    with running(*cmd, health="/", startup_timeout=startup_timeout) as p:
        yield p


def start(
    *ptwl_args: str, health: str, startup_timeout: float = 30.0, echo: str | None = None
) -> ServiceProcess:
    """Start `ptwl ARGS`, read the URL it prints, wait until `health` answers; stop it with
    `ServiceProcess.stop()`.

    With `echo`, the child's output is also printed, each line prefixed with it."""
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    process = SPAWN(ENTRY_POINTS.get(ptwl_args[0], "ptwl.cli"), list(ptwl_args), env)
    output: list[str] = []
    found = threading.Event()
    url: list[str] = []

    def pump() -> None:
        assert process.stdout is not None
        for line in process.stdout:
            output.append(line)
            if echo is not None:
                print(f"{echo}{line}", end="", flush=True)
            match = URL_PATTERN.search(line)
            if match and not url:
                url.append(match.group(1))
                found.set()
        found.set()  # its output ended: it exited before a URL, and said why; no timeout to wait out

    reader = threading.Thread(target=pump, name=f"ptwl-launcher-{ptwl_args[0]}", daemon=True)
    reader.start()
    try:
        if not found.wait(startup_timeout) or not url:
            raise RuntimeError(f"server did not start: {''.join(output)}")
        server = ServiceProcess(url[0], process, output, reader)
        deadline = time.monotonic() + startup_timeout
        with http_client(None, timeout=2.0) as client:  # one for every try (a client costs ~30 ms)
            while True:
                try:
                    # Answering at all is up: a token-guarded path says 401.
                    if client.get(server.url + health).status_code < 500:
                        return server
                except httpx.TransportError:
                    pass
                if time.monotonic() > deadline or process.poll() is not None:
                    raise RuntimeError(f"server not healthy: {''.join(output)}")
                time.sleep(0.05)
    except BaseException:
        _stop(process)
        raise


@contextmanager
def running(
    *ptwl_args: str, health: str, startup_timeout: float = 30.0, echo: str | None = None
) -> Iterator[ServiceProcess]:
    """`start`, and stop it on leaving."""
    server = start(*ptwl_args, health=health, startup_timeout=startup_timeout, echo=echo)
    try:
        yield server
    finally:
        server.stop()


def _stop(process: ChildProcess, sig: int = signal.SIGINT, timeout: float = 15.0) -> int:
    """Signal a child and wait for it; kill it if it has not exited within `timeout`. Its exit code."""
    if process.poll() is None:
        process.send_signal(sig)
    try:
        return process.wait(timeout)
    except subprocess.TimeoutExpired:
        process.kill()
        return process.wait()

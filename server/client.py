"""A small typed client for the robot server (or the link proxy in front of it).

    with RobotClient("http://127.0.0.1:8000") as robot:
        cmd = robot.ptwl(translation=[0, 0, 0.05], force_threshold=15)
        done = robot.wait(cmd.id)
        print(done.exit, done.peak_force)

Responses are the server's own pydantic models; errors raise RobotError with the status code
and the server's `detail`. `telemetry()` yields the WebSocket's messages as dicts.
"""

import json
import time
from collections.abc import Iterator
from types import TracebackType
from typing import Any, Self

import httpx
from ptwl_config import PtwlError
from websockets.exceptions import ConnectionClosedOK
from websockets.sync.client import connect

from ptwl.guard.access import bearer_header
from ptwl.guard.client import http_client
from robot_sim.telemetry import FRAMES_REV_HEADER
from server.models import (
    SENDER_HEADER,
    CommandAccepted,
    CommandStatus,
    FrameModel,
    GeometryModel,
    HealthModel,
    RobotStateModel,
    SceneModel,
    StopResult,
    TaskInfoModel,
    TaskModel,
)

LONG_POLL_CHUNK_S = 30.0


class RobotError(PtwlError):
    """The server answered 4xx/5xx."""

    def __init__(self, status_code: int, detail: Any) -> None:
        super().__init__(f"{status_code}: {detail}")
        self.status_code = status_code
        self.detail = detail


class RobotClient:
    def __init__(
        self, base_url: str = "http://127.0.0.1:8000", token: str | None = None, timeout: float = 10.0
    ):
        self.base_url = base_url.rstrip("/")
        self.token = token
        self._http = http_client(token, base_url=self.base_url, timeout=timeout)

    # ------------------------------------------------------------------ plumbing
    def __enter__(self) -> Self:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()

    def close(self) -> None:
        self._http.close()

    def _request(self, method: str, path: str, **kwargs: Any) -> Any:
        return self._answer(method, path, **kwargs).json()

    def _answer(self, method: str, path: str, **kwargs: Any) -> httpx.Response:
        """The response, or RobotError with the server's `detail` for a 4xx/5xx."""
        response = self._http.request(method, path, **kwargs)
        if response.status_code >= 400:
            try:
                detail = response.json().get("detail", response.text)
            except ValueError:
                detail = response.text
            raise RobotError(response.status_code, detail)
        return response

    # --------------------------------------------------------------------- reads
    def health(self) -> HealthModel:
        return HealthModel(**self._request("GET", "/api/health"))

    def state(self) -> RobotStateModel:
        return RobotStateModel(**self._request("GET", "/api/state"))

    def task(self) -> TaskModel:
        return TaskModel(**self._request("GET", "/api/task"))

    def presets(self) -> dict[str, Any]:
        return self._request("GET", "/api/presets")

    def geometry(self) -> GeometryModel:
        return GeometryModel(**self._request("GET", "/api/geometry"))

    def frames(self) -> list[FrameModel]:
        """The loaded scene's task frames (its own, then operators')."""
        return self.frames_at_rev()[0]

    def frames_at_rev(self) -> tuple[list[FrameModel], int | None]:
        """The task frames and the `rev` of the telemetry `frames` message they match (None from a
        server that does not say: a replay's stand-in)."""
        response = self._answer("GET", "/api/frames")
        rev = response.headers.get(FRAMES_REV_HEADER)
        return [FrameModel(**f) for f in response.json()], int(rev) if rev is not None else None

    def add_frame(self, name: str, pose: "dict[str, list[float]] | str" = "tool") -> FrameModel:
        """A task frame at the tool's pose now (`"tool"`), or at `{"position", "quaternion"}`."""
        return FrameModel(**self._request("POST", "/api/frames", json={"name": name, "pose": pose}))

    def delete_frame(self, name: str) -> FrameModel:
        return FrameModel(**self._request("DELETE", f"/api/frames/{name}"))

    def tasks(self) -> list[TaskInfoModel]:
        """Tasks with an onboard state machine (run one with `command("state_machine", task=...)`)."""
        return [TaskInfoModel(**t) for t in self._request("GET", "/api/tasks")]

    def scenes(self) -> list[SceneModel]:
        return [SceneModel(**s) for s in self._request("GET", "/api/scenes")]

    def commands(self, limit: int = 100) -> list[CommandStatus]:
        return [CommandStatus(**c) for c in self._request("GET", "/api/commands", params={"limit": limit})]

    def get(self, command_id: int, wait: float = 0.0) -> CommandStatus:
        """A command's status; with `wait` [s], held by the server until it is done or that
        passes (so the read may take that long on top of the client's timeout)."""
        read_s = self._http.timeout.read
        timeout = (
            self._http.timeout
            if read_s is None
            else httpx.Timeout(**(self._http.timeout.as_dict() | {"read": read_s + wait}))
        )
        return CommandStatus(
            **self._request("GET", f"/api/commands/{command_id}", params={"wait": wait}, timeout=timeout)
        )

    # -------------------------------------------------------------------- writes
    def command(
        self, type: str, sender: str | None = None, *, http_timeout_s: float | None = None, **params: Any
    ) -> CommandAccepted:
        """Queue a behavior: `type` is ptwl, rwe or dither; params as in the API (SI units);
        `sender` is kept in the command's record (who sent it). The command is stamped with
        `sent_at` (now, Unix time) unless it has one, so a `max_age` is judged from its sending.
        `http_timeout_s`: wait this long for the answer (a link holding it for its next contact)."""
        headers = {SENDER_HEADER: sender} if sender else None
        body = {"type": type, "sent_at": time.time(), **params}
        wait = {} if http_timeout_s is None else {"timeout": httpx.Timeout(http_timeout_s)}
        return CommandAccepted(**self._request("POST", "/api/commands", json=body, headers=headers, **wait))

    def decide(self, command_id: int, **decision: Any) -> CommandStatus:
        """Answer a running state machine's pending decision (`decision`, `choice`, and `outcome`
        or `state` as the choice needs): POST /api/commands/{id}/decision."""
        return CommandStatus(**self._request("POST", f"/api/commands/{command_id}/decision", json=decision))

    def ptwl(self, **params: Any) -> CommandAccepted:
        return self.command("ptwl", **params)

    def rwe(self, **params: Any) -> CommandAccepted:
        return self.command("rwe", **params)

    def dither(self, **params: Any) -> CommandAccepted:
        return self.command("dither", **params)

    def wait(self, command_id: int, timeout: float | None = None) -> CommandStatus:
        """Long-poll until the command is done (or `timeout` [s] passes: then as it stands)."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            chunk = (
                LONG_POLL_CHUNK_S
                if deadline is None
                else max(0.0, min(LONG_POLL_CHUNK_S, deadline - time.monotonic()))
            )
            status = self.get(command_id, wait=chunk)
            if status.status == "done" or (deadline is not None and time.monotonic() >= deadline):
                return status

    def run(self, type: str, timeout: float | None = None, **params: Any) -> CommandStatus:
        """Queue a behavior and wait for its exit."""
        return self.wait(self.command(type, **params).id, timeout)

    def stop(self, timeout: float | None = None) -> StopResult:
        """POST /api/stop; `timeout` [s] (default: the client's) bounds the wait for the answer."""
        extra = {} if timeout is None else {"timeout": timeout}
        return StopResult(**self._request("POST", "/api/stop", **extra))

    def reset_scene(
        self, name: str, seed: int | None = None, gripper_close_s: float | None = None
    ) -> StopResult:
        body = {"name": name, "seed": seed, "gripper_close_s": gripper_close_s}
        return StopResult(**self._request("POST", "/api/scene", json=body))

    # ----------------------------------------------------------------- telemetry
    def telemetry_url(self) -> str:
        return (
            self.base_url.replace("http://", "ws://", 1).replace("https://", "wss://", 1) + "/api/telemetry"
        )

    def telemetry(
        self, open_timeout: float = 10.0, idle_s: float | None = None, close_timeout: float = 10.0
    ) -> Iterator[dict[str, Any]]:
        """State, command and frames messages as they arrive; stops when the server closes. With `idle_s`,
        `{"type": "idle"}` comes whenever nothing arrived for that long (so a reader can stop).
        A reader that stops early waits at most `close_timeout` [s] for the far end to answer
        its close (websockets' default, 10 s)."""
        headers = bearer_header(self.token) or None
        # Keepalive pings off: over a multi-second link they would time out; the age of the
        # telemetry (`sent_at`) is the liveness signal instead.
        with connect(
            self.telemetry_url(),
            additional_headers=headers,
            open_timeout=open_timeout,
            close_timeout=close_timeout,
            ping_interval=None,
        ) as ws:
            while True:
                try:
                    text = ws.recv(timeout=idle_s)
                except TimeoutError:
                    yield {"type": "idle"}
                    continue
                except ConnectionClosedOK:
                    return
                yield json.loads(text)

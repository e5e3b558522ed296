"""A recording served as the robot: the same read routes and telemetry socket, answered from the
recording at the playhead, so the console shows a replay exactly as it showed the session.

Nothing can be sent to a recording: commands, STOP, scene resets and new frames answer 409 saying so.
`GET/PUT /_replay` is the playhead (play, pause, speed, position), as the link's `/_link/*` is
the link's. Behind the same access guard as the robot (Host, Origin, token).
"""

import asyncio
import contextlib
import json
import time
from typing import Annotated, Any

from fastapi import APIRouter, FastAPI, HTTPException, Query, WebSocket, WebSocketDisconnect
from pydantic import BaseModel, ConfigDict, Field

from ptwl.guard.access import AccessPolicy
from ptwl.guard.stack import install_guards
from ptwl.recording.replay.player import MAX_SPEED, SPEEDS, Player
from ptwl.recording.replay.timeline import Timeline
from server.errors import install_error_handlers
from server.models import (
    CommandStatus,
    FrameModel,
    GeometryModel,
    HealthModel,
    RobotStateModel,
    TaskModel,
)
from server.routes import robot as robot_routes
from server.routes import scenes as scene_routes
from server.telemetry import stamped

SEND_EVERY_S = 0.02  # [s] the socket's cadence: 50 Hz, the robot's default telemetry rate
KEEPALIVE_S = 0.25  # [s] paused, the current state is re-sent this often: a replay is not stale


class ReplayControl(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)

    playing: bool | None = Field(None, description="play (true) or pause (false)")
    speed: float | None = Field(None, ge=min(SPEEDS), le=MAX_SPEED, description="x real time")
    position_s: float | None = Field(None, ge=0.0, description="[s] from the recording's start")


class ReplayStatus(BaseModel):
    file: str
    duration_s: float = Field(description="[s] from the first message to the last")
    position_s: float = Field(description="[s] the playhead, from the start")
    playing: bool
    speed: float
    speeds: list[float] = Field(description="the speeds a console offers")
    jumps: int = Field(description="how many times the position was set; a reader starts afresh")


def create_replay_app(timeline: Timeline, player: Player, policy: AccessPolicy) -> FastAPI:
    app = FastAPI(title="ptwl replay", version="0.1.0", description=f"A replay of {timeline.path}")
    install_error_handlers(app)
    install_guards(app, policy)
    api = APIRouter(prefix="/api")
    refused = f"this is a replay of {timeline.path.name}: nothing can be sent to a recording"

    def here() -> int:
        return player.now().position_ns

    @api.get("/health", response_model=HealthModel)
    async def health() -> HealthModel:
        state = timeline.state_at(here())
        return HealthModel(
            status="ok",
            sim_time=state["sim_time"],
            faults=state.get("faults", 0),
            last_fault=None,
            real_time_lag=0.0,
            queued=sum(c["status"] == "queued" for c in timeline.commands_at(here())),
            instance=state.get("instance", "replay"),
            long_polls=0,
        )

    @api.get("/state", response_model=RobotStateModel)
    async def state() -> dict[str, Any]:
        return timeline.state_at(here())

    @api.get("/task", response_model=TaskModel)
    async def task() -> dict[str, Any]:
        found = timeline.task_at(here())
        if found is None:
            raise HTTPException(404, "the recording has no task record yet at this time")
        return found

    @api.get("/geometry", response_model=GeometryModel)
    async def geometry() -> dict[str, Any]:
        return timeline.geometry_at(here())

    @api.get("/frames", response_model=list[FrameModel])
    async def frames() -> list[dict[str, Any]]:
        return timeline.frames_at(here())

    api.add_api_route("/presets", robot_routes.presets, methods=["GET"])
    api.add_api_route("/scenes", scene_routes.scenes, methods=["GET"])
    api.add_api_route("/tasks", scene_routes.tasks, methods=["GET"])

    @api.get("/commands", response_model=list[CommandStatus])
    async def commands(limit: Annotated[int, Query(ge=1, le=1000)] = 100) -> list[dict[str, Any]]:
        return timeline.commands_at(here())[-limit:]

    @api.get("/commands/{command_id}", response_model=CommandStatus)
    async def command(command_id: int) -> dict[str, Any]:
        for record in timeline.commands_at(here()):
            if record["id"] == command_id:
                return record
        raise HTTPException(404, f"no command {command_id} in the recording up to the playhead")

    @api.post("/commands", status_code=409)
    @api.post("/stop", status_code=409)
    @api.post("/scene", status_code=409)
    @api.post("/frames", status_code=409)
    async def read_only() -> None:
        raise HTTPException(409, refused)

    @app.get("/_replay", response_model=ReplayStatus)
    async def status() -> ReplayStatus:
        return _status(timeline, player)

    @app.put("/_replay", response_model=ReplayStatus)
    async def control(body: ReplayControl) -> ReplayStatus:
        if body.position_s is not None and body.position_s > timeline.duration_s:
            raise HTTPException(
                422, f"position_s: must be in [0, {timeline.duration_s:.3f}] s, got {body.position_s:g}"
            )
        position_ns = None if body.position_s is None else timeline.start_ns + int(body.position_s * 1e9)
        player.set(playing=body.playing, speed=body.speed, position_ns=position_ns)
        return _status(timeline, player)

    @app.websocket("/api/telemetry")
    async def telemetry(ws: WebSocket) -> None:
        await ws.accept()
        with contextlib.suppress(WebSocketDisconnect, RuntimeError):
            await _stream(ws, timeline, player)

    app.include_router(api)
    return app


async def _stream(ws: WebSocket, timeline: Timeline, player: Player) -> None:
    """From the playhead on, each message when the playhead passes it; after a seek, the task
    frames and the state there; while paused, that state again every KEEPALIVE_S."""
    closed = asyncio.create_task(ws.receive())
    try:
        jumps, last_ns = -1, 0
        last_sent = 0.0
        while not closed.done():
            head = player.now()
            if player.jumps != jumps:
                jumps, last_ns = player.jumps, head.position_ns
                texts = [*timeline.frames_messages_at(last_ns), json.dumps(timeline.state_at(last_ns))]
            else:
                texts = [o.text for o in timeline.between(last_ns, head.position_ns)]
                last_ns = head.position_ns
                if not texts and time.monotonic() - last_sent > KEEPALIVE_S:
                    texts = [json.dumps(timeline.state_at(last_ns))]
            for text in texts:
                await ws.send_text(stamped(text))
            if texts:
                last_sent = time.monotonic()
            await asyncio.wait({closed}, timeout=SEND_EVERY_S)
    finally:
        closed.cancel()


def _status(timeline: Timeline, player: Player) -> ReplayStatus:
    head = player.now()
    return ReplayStatus(
        file=str(timeline.path),
        duration_s=timeline.duration_s,
        position_s=(head.position_ns - timeline.start_ns) / 1e9,
        playing=head.playing,
        speed=head.speed,
        speeds=list(SPEEDS),
        jumps=player.jumps,
    )

"""The robot server's FastAPI app: one simulation thread, REST by resource, WebSocket telemetry."""

import asyncio
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

from fastapi import FastAPI

from ptwl.guard.stack import install_guards
from robot_sim.command_book import CommandRecord
from robot_sim.limits import COMMAND_HISTORY_MAX, COMMAND_QUEUE_MAX
from server.commands import CommandBook, CommandIds
from server.config import ServerConfig
from server.errors import install_error_handlers
from server.models import COMMON_RESPONSES
from server.recording import RecordingThread, session_metadata
from server.routes import commands, debug, frames, robot, scenes, telemetry
from server.runner import SimRunner, command_event
from server.telemetry import Broadcaster
from server.waiters import Waiters


def create_app(config: ServerConfig) -> FastAPI:
    ids = CommandIds(config.ids_file())  # here, not in lifespan: a bad record stops `ptwl serve` in a line

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        loop = asyncio.get_running_loop()
        broadcaster = Broadcaster()
        waiters = Waiters()

        def announce(text: str, command_id: int, done: bool) -> None:
            broadcaster.publish(text)
            if done:
                waiters.notify(command_id)

        recording: RecordingThread | None = None

        def on_change(record: CommandRecord) -> None:
            # Any thread, under the book's lock: serialise now (a snapshot), deliver on the loop.
            text = command_event(record)
            loop.call_soon_threadsafe(announce, text, record.id, record.status == "done")
            if recording is not None:
                recording.command(text)

        def publish(text: str) -> None:
            loop.call_soon_threadsafe(broadcaster.publish, text)
            if recording is not None:
                recording.state(text)

        book = CommandBook(COMMAND_QUEUE_MAX, COMMAND_HISTORY_MAX, on_change, ids, config.sent_at_skew_s)
        runner = SimRunner(config.scene, config.seed, config.telemetry_hz, book, publish)
        if config.record is not None:
            recording = RecordingThread(config.record, session_metadata(config))
            runner.on_step = recording.step
            runner.on_scene_loaded = recording.geometry
            recording.start()
        app.state.broadcaster = broadcaster
        app.state.waiters = waiters
        app.state.book = book
        app.state.runner = runner
        runner.start()
        try:
            yield
        finally:
            runner.close()
            if recording is not None:
                recording.close()

    app = FastAPI(
        title="ptwl robot server",
        version="0.1.0",
        description=(
            "A simulated IRB120-class arm under admittance control running PTWL, RWE and Dither. "
            "SI units (m, rad, N, N m, s); poses {position, quaternion [w x y z]} in the robot "
            "base frame; wrenches [fx fy fz tx ty tz], environment on the port, base axes."
        ),
        lifespan=lifespan,
        responses=COMMON_RESPONSES,
    )
    app.state.config = config
    install_error_handlers(app)
    install_guards(app, config.access())
    for module in (commands, frames, robot, scenes, telemetry):
        app.include_router(module.router)
    if config.fault_injection:
        app.include_router(debug.router)
    return app

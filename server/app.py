"""The robot server's FastAPI app: one simulation thread, REST by resource, WebSocket telemetry."""

import asyncio
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

from fastapi import FastAPI

from server.commands import CommandBook
from server.config import BODY_LIMIT_BYTES, HISTORY_MAX, QUEUE_MAX, ServerConfig
from server.errors import BodyLimitMiddleware, install_error_handlers
from server.routes import commands, debug, robot, scenes, telemetry
from server.runner import SimRunner
from server.telemetry import Broadcaster
from server.waiters import Waiters


def create_app(config: ServerConfig) -> FastAPI:
    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        loop = asyncio.get_running_loop()
        broadcaster = Broadcaster()
        waiters = Waiters()
        book = CommandBook(QUEUE_MAX, HISTORY_MAX)
        runner = SimRunner(
            config.scene,
            config.seed,
            config.telemetry_hz,
            book,
            publish=lambda text: loop.call_soon_threadsafe(broadcaster.publish, text),
            on_command_done=lambda cid: loop.call_soon_threadsafe(waiters.notify, cid),
        )
        app.state.broadcaster = broadcaster
        app.state.waiters = waiters
        app.state.book = book
        app.state.runner = runner
        runner.start()
        try:
            yield
        finally:
            runner.close()

    app = FastAPI(
        title="ptwl robot server",
        version="0.1.0",
        description=(
            "A simulated IRB120-class arm under admittance control running PTWL, RWE and Dither. "
            "SI units (m, rad, N, N m, s); poses {position, quaternion [w x y z]} in the robot "
            "base frame; wrenches [fx fy fz tx ty tz], environment on the port, base axes."
        ),
        lifespan=lifespan,
    )
    app.state.config = config
    install_error_handlers(app)
    app.add_middleware(BodyLimitMiddleware, limit=BODY_LIMIT_BYTES)
    for module in (commands, robot, scenes, telemetry):
        app.include_router(module.router)
    if config.fault_injection:
        app.include_router(debug.router)
    return app

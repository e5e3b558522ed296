"""Run the robot server with uvicorn on a socket we bind ourselves (so port 0 works)."""

import signal
from dataclasses import replace

import uvicorn

from ptwl.guard.listen import bind, listening_url
from robot_sim.warm import warm_up
from server.app import create_app
from server.config import ServerConfig


def serve(config: ServerConfig) -> None:
    config.check()
    warm_s = warm_up()  # before the port opens: no command waits on a compile
    sock = bind(config.host, config.port)
    port = sock.getsockname()[1]
    print(
        f"ptwl serve: robot server on {listening_url(sock)} "
        f"(scene {config.scene}, telemetry {config.telemetry_hz:g} Hz, "
        f"{'token required' if config.token else 'no token: loopback only'}; "
        f"compiled tick loaded in {warm_s:.1f} s)",
        flush=True,
    )
    app = create_app(replace(config, port=port))  # the Origin check needs the port really bound
    # No permessage-deflate on the telemetry socket: deflating every state for every client takes
    # the CPU the 1 kHz loop shares with it (100 clients: ~44 Hz each with one core hogged).
    uvicorn_config = uvicorn.Config(app, log_level="warning", lifespan="on", ws_per_message_deflate=False)
    server = uvicorn.Server(uvicorn_config)
    # uvicorn shuts down gracefully on SIGINT/SIGTERM, then re-raises the signal to the handler
    # that was there before it; make that one a no-op so a clean stop exits 0.
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, _already_handled)
    server.run(sockets=[sock])
    print("ptwl serve: stopped", flush=True)


def _already_handled(signum: int, frame: object) -> None:
    """The shutdown this signal asked for has happened."""

"""Run the robot server with uvicorn on a socket we bind ourselves (so port 0 works)."""

import signal
import socket
from dataclasses import replace

import uvicorn

from server.app import create_app
from server.config import ServerConfig


def bind(host: str, port: int) -> socket.socket:
    family, kind, proto, _, address = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)[0]
    sock = socket.socket(family, kind, proto)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    sock.bind(address)
    sock.listen(128)
    sock.set_inheritable(True)
    return sock


def serve(config: ServerConfig) -> None:
    config.check()
    sock = bind(config.host, config.port)
    host, port = sock.getsockname()[0:2]
    shown = f"[{host}]" if ":" in host else host
    print(
        f"ptwl serve: robot server on http://{shown}:{port} "
        f"(scene {config.scene}, telemetry {config.telemetry_hz:g} Hz, "
        f"{'token required' if config.token else 'no token: loopback only'})",
        flush=True,
    )
    app = create_app(replace(config, port=port))  # the Origin check needs the port really bound
    server = uvicorn.Server(uvicorn.Config(app, log_level="warning", lifespan="on"))
    # uvicorn shuts down gracefully on SIGINT/SIGTERM, then re-raises the signal to the handler
    # that was there before it; make that one a no-op so a clean stop exits 0.
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, _already_handled)
    server.run(sockets=[sock])
    print("ptwl serve: stopped", flush=True)


def _already_handled(signum: int, frame: object) -> None:
    """The shutdown this signal asked for has happened."""

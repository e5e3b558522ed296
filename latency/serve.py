"""Run the proxy with uvicorn (`ptwl proxy`)."""

import ipaddress
import signal
import socket
from dataclasses import dataclass
from pathlib import Path

import uvicorn

from latency.link import Link
from latency.named import LinkConfigError, named_profile
from latency.profile import LinkProfile
from latency.proxy import LinkProxy
from latency.record import Recorder


@dataclass(frozen=True)
class ProxyConfig:
    upstream: str = "http://127.0.0.1:8000"
    host: str = "127.0.0.1"
    port: int = 8001
    profile: str | None = None
    uplink: float | None = None
    downlink: float | None = None
    record: Path | None = None
    token: str | None = None

    def initial_profile(self) -> LinkProfile:
        base = named_profile(self.profile) if self.profile else LinkProfile()
        update = {k: v for k, v in (("uplink", self.uplink), ("downlink", self.downlink)) if v is not None}
        return base.merged(update) if update else base


def _loopback(host: str) -> bool:
    try:
        return host == "localhost" or ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def serve_proxy(config: ProxyConfig) -> None:
    if not _loopback(config.host) and not config.token:
        raise LinkConfigError(
            f"refusing to bind {config.host}: a non-loopback address needs an access token (--token)"
        )
    profile = config.initial_profile()
    recorder = Recorder(config.record) if config.record else None
    proxy = LinkProxy(config.upstream, Link(profile, recorder=recorder), token=config.token)
    family, kind, proto, _, address = socket.getaddrinfo(config.host, config.port, type=socket.SOCK_STREAM)[0]
    sock = socket.socket(family, kind, proto)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    sock.bind(address)
    host, port = sock.getsockname()[0:2]
    print(
        f"ptwl proxy: link on http://{host}:{port} -> {config.upstream} "
        f"(uplink {profile.uplink:g} s, downlink {profile.downlink:g} s)",
        flush=True,
    )
    server = uvicorn.Server(uvicorn.Config(proxy.app(), log_level="warning", lifespan="on"))
    for sig in (signal.SIGINT, signal.SIGTERM):  # uvicorn re-raises after its graceful stop
        signal.signal(sig, lambda signum, frame: None)
    server.run(sockets=[sock])
    print("ptwl proxy: stopped", flush=True)

"""Run the proxy with uvicorn (`ptwl proxy`)."""

import signal
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import uvicorn

from latency.link import Link
from latency.named import named_profile
from latency.plan_file import read_schedule
from latency.profile import LinkProfile
from latency.proxy import LinkProxy
from latency.record import open_recorder
from ptwl.guard.access import AccessPolicy, check_token_setting
from ptwl.guard.listen import bind, listening_url


@dataclass(frozen=True)
class ProxyConfig:
    upstream: str = "http://127.0.0.1:8000"
    host: str = "127.0.0.1"
    port: int = 8001
    profile: str | None = None
    schedule: Path | None = None  # a schedule file (TOML) or ION contact plan, over the profile's
    ground_node: int = 1  # an ION plan's nodes: ground (uplink from) and robot
    robot_node: int = 2
    uplink: float | None = None
    downlink: float | None = None
    record: Path | None = None
    token: str | None = None
    allow_hosts: tuple[str, ...] = ()
    allow_origins: tuple[str, ...] = ()

    def initial_profile(self) -> LinkProfile:
        base = named_profile(self.profile) if self.profile else LinkProfile()
        update: dict[str, Any] = {
            k: v for k, v in (("uplink", self.uplink), ("downlink", self.downlink)) if v is not None
        }
        if self.schedule is not None:
            update["schedule"] = read_schedule(self.schedule, self.ground_node, self.robot_node).model_dump()
        return base.merged(update) if update else base


def serve_proxy(config: ProxyConfig) -> None:
    check_token_setting(config.token, config.host)
    profile = config.initial_profile()
    recorder = open_recorder(config.record) if config.record else None
    sock = bind(config.host, config.port)
    port = sock.getsockname()[1]
    access = AccessPolicy(config.host, port, config.token, config.allow_hosts, config.allow_origins)
    proxy = LinkProxy(config.upstream, Link(profile, recorder=recorder), access)
    print(
        f"ptwl proxy: link on {listening_url(sock)} -> {config.upstream} "
        f"(uplink {profile.uplink:g} s, downlink {profile.downlink:g} s"
        f"{', with a schedule' if profile.schedule is not None else ''})",
        flush=True,
    )
    # No permessage-deflate towards clients: the link models a message by its JSON size, so
    # compressing on loopback only spends CPU (at 100 clients x 50 Hz it was a fifth of the
    # link's time, and the link then fell to ~33 Hz a client with one core hogged).
    uvicorn_config = uvicorn.Config(
        proxy.app(), log_level="warning", lifespan="on", ws_per_message_deflate=False
    )
    server = uvicorn.Server(uvicorn_config)
    for sig in (signal.SIGINT, signal.SIGTERM):  # uvicorn re-raises after its graceful stop
        signal.signal(sig, lambda signum, frame: None)
    server.run(sockets=[sock])
    print("ptwl proxy: stopped", flush=True)

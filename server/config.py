"""Server settings (command line and environment)."""

import ipaddress
import socket
from dataclasses import dataclass

DEFAULT_PORT = 8000
QUEUE_MAX = 64  # queued commands; beyond it POST /api/commands answers 429
BODY_LIMIT_BYTES = 64 * 1024
HISTORY_MAX = 1000  # finished commands kept for GET /api/commands


class ConfigError(ValueError):
    """A setting that cannot work; the message says what to do."""


def is_loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        try:
            return all(ipaddress.ip_address(a[4][0]).is_loopback for a in socket.getaddrinfo(host, None))
        except OSError:
            return False


@dataclass(frozen=True)
class ServerConfig:
    host: str = "127.0.0.1"
    port: int = DEFAULT_PORT
    scene: str = "surface"
    seed: int | None = None
    telemetry_hz: float = 50.0
    token: str | None = None
    fault_injection: bool = False  # test hook: POST /api/_debug/fault

    def check(self) -> None:
        if not is_loopback(self.host) and not self.token:
            raise ConfigError(
                f"refusing to bind {self.host}: a non-loopback address needs an access token "
                "(--token or PTWL_TOKEN)"
            )
        if not 1.0 <= self.telemetry_hz <= 500.0:
            raise ConfigError(f"--telemetry-hz must be in [1, 500], got {self.telemetry_hz:g}")

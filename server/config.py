"""Server settings (command line and environment)."""

from dataclasses import dataclass
from pathlib import Path

from guard.access import AccessConfigError, AccessPolicy, check_token_setting, is_loopback
from guard.body_limit import BODY_LIMIT_BYTES
from recording.paths import check_record_path

DEFAULT_PORT = 8000
QUEUE_MAX = 64  # queued commands; beyond it POST /api/commands answers 429
HISTORY_MAX = 1000  # finished commands kept for GET /api/commands


ConfigError = AccessConfigError  # a setting that cannot work; the message says what to do

__all__ = ["BODY_LIMIT_BYTES", "ConfigError", "ServerConfig", "is_loopback"]


@dataclass(frozen=True)
class ServerConfig:
    host: str = "127.0.0.1"
    port: int = DEFAULT_PORT
    scene: str = "surface"
    seed: int | None = None
    telemetry_hz: float = 50.0
    token: str | None = None
    fault_injection: bool = False  # test hook: POST /api/_debug/fault
    allow_hosts: tuple[str, ...] = ()  # Host names beyond the bind address (a DNS name, a proxy's)
    allow_origins: tuple[str, ...] = ()  # browser origins beyond the server's own
    record: Path | None = None  # an MCAP file to record the session into

    def access(self) -> AccessPolicy:
        return AccessPolicy(self.host, self.port, self.token, self.allow_hosts, self.allow_origins)

    def check(self) -> None:
        check_token_setting(self.token, self.host)
        if self.record is not None:
            check_record_path(self.record)
        if not 1.0 <= self.telemetry_hz <= 500.0:
            raise ConfigError(f"--telemetry-hz must be in [1, 500], got {self.telemetry_hz:g}")

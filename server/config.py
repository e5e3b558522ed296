"""Server settings (command line and environment)."""

import os
from dataclasses import dataclass, field
from pathlib import Path

from ptwl_config import ConfigError  # a setting that cannot work; the message says what to do

from ptwl.guard.access import AccessPolicy, check_token_setting, is_loopback
from ptwl.guard.body_limit import BODY_LIMIT_BYTES
from ptwl.recording.paths import check_record_path
from robot_sim.limits import SENT_AT_SKEW_S

DEFAULT_PORT = 8000
MAX_SENT_AT_SKEW_S = 3600.0  # [s] more would let a stamp defeat max_age by an hour or more
IDS_FILE = "command-ids.json"  # in the data dir: ids on record, so none repeats after a restart


def default_data_dir() -> Path:
    """Where the server keeps what must outlive a run: $XDG_STATE_HOME/ptwl, ~/.local/state/ptwl."""
    state_home = os.environ.get("XDG_STATE_HOME") or str(Path.home() / ".local" / "state")
    return Path(state_home) / "ptwl"


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
    data_dir: Path = field(default_factory=default_data_dir)  # the command id record lives here
    sent_at_skew_s: float = SENT_AT_SKEW_S

    def ids_file(self) -> Path:
        return self.data_dir / IDS_FILE

    def access(self) -> AccessPolicy:
        return AccessPolicy(self.host, self.port, self.token, self.allow_hosts, self.allow_origins)

    def check(self) -> None:
        check_token_setting(self.token, self.host)
        if self.record is not None:
            check_record_path(self.record)
        if not 1.0 <= self.telemetry_hz <= 500.0:
            raise ConfigError(f"--telemetry-hz must be in [1, 500], got {self.telemetry_hz:g}")
        if not 0.0 <= self.sent_at_skew_s <= MAX_SENT_AT_SKEW_S:  # NaN fails this too
            raise ConfigError(
                f"--sent-at-skew must be in [0, {MAX_SENT_AT_SKEW_S:g}] s, got {self.sent_at_skew_s:g}"
            )
        try:
            self.data_dir.mkdir(parents=True, exist_ok=True)
        except OSError as err:
            raise ConfigError(f"--data-dir {self.data_dir} cannot be created: {err.strerror}") from None
        if not os.access(self.data_dir, os.W_OK | os.X_OK):
            raise ConfigError(f"--data-dir {self.data_dir} is not writable (command ids are kept there)")

"""The access policy: which Host names a server answers to, which browser origins may reach it,
and the access token.

Why each rule exists:
- Host: a DNS-rebinding page reaches 127.0.0.1 under its own name (`evil.example:8000`); a server
  that answers only to its bind names never sees that request through.
- Origin: browsers send it on every WebSocket handshake and every cross-origin POST (also
  no-cors), so refusing a foreign Origin stops a page the operator happens to visit from
  commanding or stopping the robot. Scripts send none and are judged by the token.
- Token: required off loopback; at least MIN_TOKEN_CHARS with no whitespace, compared in
  constant time.
"""

import hmac
import ipaddress
import socket
from dataclasses import dataclass, field
from urllib.parse import urlsplit

from ptwl_config import ConfigError

MIN_TOKEN_CHARS = 16
LOOPBACK_NAMES = frozenset({"127.0.0.1", "localhost", "::1"})


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


def check_token_setting(token: str | None, bind_host: str) -> None:
    """Refuse a non-loopback bind without a token, and a token too short or blank to mean anything."""
    if token is None:
        if not is_loopback(bind_host):
            raise ConfigError(
                f"refusing to bind {bind_host}: a non-loopback address needs an access token "
                "(--token or PTWL_TOKEN)"
            )
        return
    if len(token) < MIN_TOKEN_CHARS or any(c.isspace() for c in token):
        raise ConfigError(
            f"access token must be at least {MIN_TOKEN_CHARS} characters with no whitespace "
            f"(got {len(token)}); e.g. python -c 'import secrets; print(secrets.token_urlsafe(24))'"
        )


def split_host(value: str) -> tuple[str, int | None]:
    """`name[:port]` or `[v6]:port` -> (name lowercased, port or None); ('', None) if malformed."""
    parts = urlsplit("//" + value.strip())
    try:
        return (parts.hostname or ""), parts.port
    except ValueError:
        return "", None


@dataclass(frozen=True)
class AccessPolicy:
    """Host names this server answers to and browser origins it accepts, plus its token."""

    bind_host: str
    port: int
    token: str | None = None
    extra_hosts: tuple[str, ...] = ()
    extra_origins: tuple[str, ...] = ()
    names: frozenset[str] = field(init=False)

    def __post_init__(self) -> None:
        names = {self.bind_host.lower(), *(h.lower() for h in self.extra_hosts)}
        if is_loopback(self.bind_host) or self.bind_host in ("0.0.0.0", "::"):
            names |= LOOPBACK_NAMES
        if self.bind_host in ("0.0.0.0", "::"):
            names.add(socket.gethostname().lower())
        object.__setattr__(self, "names", frozenset(names))

    def host_problem(self, host_header: str | None) -> str | None:
        if not host_header:
            return "missing Host header"
        # The name, not the port: an SSH tunnel may change the port, a rebinding page the name.
        if split_host(host_header)[0] not in self.names:
            return (
                f"Host {host_header!r} is not one of this server's names "
                f"({', '.join(sorted(self.names))}); add it with --allow-host"
            )
        return None

    def origin_problem(self, origin: str | None) -> str | None:
        """None if allowed: no Origin (not a browser), this server's own origin, or --allow-origin."""
        if origin is None:
            return None
        if origin.rstrip("/") in self.extra_origins:
            return None
        parts = urlsplit(origin)
        try:
            port = parts.port or (443 if parts.scheme == "https" else 80)
        except ValueError:
            port = -1
        if parts.scheme in ("http", "https") and (parts.hostname or "") in self.names and port == self.port:
            return None
        return f"Origin {origin!r} may not use this server; add it with --allow-origin"

    def token_problem(self, presented: str | None) -> tuple[int, str] | None:
        """(status, reason) if the token is missing or wrong; None if fine or none is set."""
        if self.token is None:
            return None
        if presented is None:
            return 401, "missing access token: send Authorization: Bearer <token> (WebSocket: ?token=)"
        if not hmac.compare_digest(presented.encode(), self.token.encode()):
            return 403, "access token rejected"
        return None


def bearer_header(token: str | None) -> dict[str, str]:
    """The request header a client sends its token in (none without a token)."""
    return {"Authorization": f"Bearer {token}"} if token else {}


def bearer(header: str | None) -> str | None:
    if header and header.lower().startswith("bearer "):
        return header[7:].strip()
    return None

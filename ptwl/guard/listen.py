"""The listening socket every server binds itself (so port 0 works and the port is known before
uvicorn starts), with a bounded send buffer.

SEND_BUFFER_BYTES is set on the listener, so every accepted connection inherits it (Linux) in
place of autotuning up to 4 MiB: a telemetry client that stops reading then holds at most this in
the kernel (doubled by Linux for its bookkeeping), about 7 s of 50 Hz states; after that its
outbox (ptwl/guard/outbox.py) holds what waits, by the rule there (recent states, events up to a
backlog, then 1013). Without it, a stalled client could
hide a minute of telemetry in the kernel before anything of ours noticed.
"""

import socket

SEND_BUFFER_BYTES = 256 * 1024


def bind(host: str, port: int) -> socket.socket:
    family, kind, proto, _, address = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)[0]
    sock = socket.socket(family, kind, proto)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, SEND_BUFFER_BYTES)
    sock.bind(address)
    sock.listen(128)
    sock.set_inheritable(True)
    return sock


def host_port(host: str, port: int) -> str:
    """host:port as a URL writes it, an IPv6 address in brackets."""
    return f"[{host}]:{port}" if ":" in host else f"{host}:{port}"


def http_url(host: str, port: int) -> str:
    """The URL of a server listening on (host, port)."""
    return f"http://{host_port(host, port)}"


def listening_url(sock: socket.socket) -> str:
    """The URL of the address a bound socket listens on (the port chosen for port 0)."""
    host, port = sock.getsockname()[0:2]
    return http_url(host, port)

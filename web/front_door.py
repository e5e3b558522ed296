"""The console's front door: the access policy in front of viser, which checks no Origin.

viser's server (websockets' `serve`) accepts a WebSocket from any page, so a page on another
origin could open it and press Send. Browsers connect here instead; each connection's request
head is judged by ptwl/guard/ (Host, Origin) before a byte reaches viser, which listens on an
ephemeral loopback port. viser answers one request per connection (static files or the
WebSocket upgrade), so judging the first head judges the whole connection.

A page could still find viser's own port by scanning 127.0.0.1, so the front door marks every
head it passes with a per-run secret (`X-Ptwl-Front-Door`, any such header from the client is
dropped first) and `admit_only_through` makes viser drop a WebSocket without it before a
message is sent or read.
"""

import asyncio
import contextlib
import json
import logging
import secrets
import threading
from typing import Any
from urllib.parse import urlsplit

from ptwl_config import PtwlError

from ptwl.guard.access import AccessPolicy
from ptwl.guard.asgi import denial
from ptwl.guard.listen import host_port
from ptwl.guard.page_headers import CONSOLE_CSP, page_headers

MAX_HEAD_BYTES = 64 * 1024
MARK = "x-ptwl-front-door"
REASONS = {400: "Bad Request", 403: "Forbidden", 431: "Request Header Fields Too Large", 503: "Unavailable"}


def _parse_head(head: bytes) -> tuple[str, dict[str, str]]:
    lines = head.decode("latin-1").split("\r\n")
    parts = lines[0].split(" ")
    target = parts[1] if len(parts) > 1 else "/"
    headers: dict[str, str] = {}
    for line in lines[1:]:
        name, sep, value = line.partition(":")
        if sep:
            headers[name.strip().lower()] = value.strip()
    return target, headers


def _with_headers(head: bytes, headers: dict[str, str]) -> bytes:
    """An HTTP head with `headers` (lowercase names) set: any of the same name it had removed."""
    lines = head.decode("latin-1").split("\r\n")[:-2]  # the head ends with an empty line
    kept = [line for line in lines if line.partition(":")[0].strip().lower() not in headers]
    return ("\r\n".join([*kept, *(f"{k}: {v}" for k, v in headers.items())]) + "\r\n\r\n").encode("latin-1")


def _marked(head: bytes, secret: str) -> bytes:
    """The request head with any client-sent mark removed and ours added."""
    return _with_headers(head, {MARK: secret})


def admit_only_through(front_door: "FrontDoor", viser_server: Any) -> None:
    """Make viser refuse any WebSocket that did not come through `front_door`.

    Uses viser's WebsockServer internals (its connect callbacks run before any message moves,
    and it keeps each raw connection); an AttributeError here if a viser release renames them."""
    infra = viser_server._websock_server
    connections = infra._live_connections

    async def check(client: Any) -> None:
        connection = connections[client.client_id]
        if connection.request.headers.get(MARK) == front_door.secret:
            return
        # viser registered the connection before its callbacks ran and frees it only in a
        # `finally` that begins after them: forget it here, or every refused probe stays (issue
        # 26: +93 MB over 6,000 probes). Raising stops viser building the client's handle.
        connections.pop(client.client_id, None)
        infra._client_state_from_id.pop(client.client_id, None)
        await connection.close(1008, "not through the console's front door")
        raise NotThroughFrontDoor(client.client_id)

    infra._client_connect_cb.insert(0, check)  # before viser builds the client's handle
    logging.getLogger("websockets.server").addFilter(_quiet_refusals)


class NotThroughFrontDoor(PtwlError, PermissionError):
    """A WebSocket on viser's own port without the front door's mark (refused, closed 1008)."""


def _quiet_refusals(record: logging.LogRecord) -> bool:
    """websockets logs a handler's exception with its traceback: for a refusal we raised on
    purpose that is ~600 bytes of log per probe, so none."""
    return not (record.exc_info and isinstance(record.exc_info[1], NotThroughFrontDoor))


def _refusal(status: int, detail: str) -> bytes:
    body = json.dumps({"detail": detail}).encode()
    head = (
        f"HTTP/1.1 {status} {REASONS.get(status, 'Refused')}\r\nContent-Type: application/json\r\n"
        f"Content-Length: {len(body)}\r\nConnection: close\r\n\r\n"
    )
    return _with_headers(head.encode(), page_headers(CONSOLE_CSP)) + body


async def _pipe(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
    with contextlib.suppress(ConnectionError, OSError):
        while chunk := await reader.read(65536):
            writer.write(chunk)
            await writer.drain()
    with contextlib.suppress(ConnectionError, OSError, RuntimeError):
        writer.close()


class FrontDoor:
    """Listen on (host, port); pass allowed connections to viser at 127.0.0.1:`inner_port`.

    Bound before viser exists (`inner_port` is set after): viser takes an ephemeral port, and
    bound first it could take the very port just probed free for the front door (a CI run's
    console failed so: viser on 35815, then the front door's bind of 35815 refused)."""

    def __init__(self, host: str, port: int, allow_origins: tuple[str, ...] = ()) -> None:
        self._host, self._port = host, port
        self.inner_port: int | None = None  # viser's port; until set, "console not ready" (503)
        self._allow_origins = allow_origins
        self.secret = secrets.token_urlsafe(24)
        self.policy: AccessPolicy | None = None
        self.port_bound: int | None = None
        self._loop = asyncio.new_event_loop()
        self._server: asyncio.Server | None = None
        self._thread = threading.Thread(target=self._loop.run_forever, name="ptwl-front-door", daemon=True)

    def start(self) -> int:
        """Bind and serve; the port actually bound. A bind refused stops the thread again."""
        self._thread.start()
        try:
            asyncio.run_coroutine_threadsafe(self._bind(), self._loop).result(timeout=10.0)
        except BaseException:
            self.close()
            raise
        assert self.port_bound is not None
        return self.port_bound

    @property
    def address(self) -> str:
        """host:port as a URL writes it (an IPv6 host in brackets); after start()."""
        return host_port(self._host, self.port_bound or 0)

    async def _bind(self) -> None:
        server = await asyncio.start_server(self._handle, self._host, self._port, reuse_address=True)
        # The policy is set here, on the loop, before any connection's handler can run (they
        # wait for this coroutine to yield): set by start() after, a browser reconnecting to a
        # fixed port in between met no policy.
        self._server = server  # here, not from start(): closed by close() even if start() timed out
        port = self.port_bound = int(server.sockets[0].getsockname()[1])
        self.policy = AccessPolicy(self._host, port, None, (), self._allow_origins)

    def close(self) -> None:
        """Stop listening, end the connections it still carries, and join its thread."""
        if self._thread.is_alive():
            with contextlib.suppress(TimeoutError, RuntimeError):
                asyncio.run_coroutine_threadsafe(self._shut(), self._loop).result(timeout=5.0)
            self._loop.call_soon_threadsafe(self._loop.stop)
            self._thread.join(timeout=5.0)
        if not self._thread.is_alive() and not self._loop.is_closed():
            self._loop.close()

    async def _shut(self) -> None:
        if self._server is not None:
            self._server.close()
        others = [task for task in asyncio.all_tasks() if task is not asyncio.current_task()]
        for task in others:
            task.cancel()
        await asyncio.gather(*others, return_exceptions=True)

    async def _handle(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        try:
            await self._serve(reader, writer)
        finally:  # at any stage, also when close() cancels it before the pipes: the browser's end
            with contextlib.suppress(ConnectionError, OSError, RuntimeError):
                writer.close()

    async def _serve(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        try:
            head = await reader.readuntil(b"\r\n\r\n")
        except asyncio.LimitOverrunError:
            writer.write(_refusal(431, f"request head over {MAX_HEAD_BYTES} bytes"))
            await _close(writer)
            return
        except (asyncio.IncompleteReadError, ConnectionError):
            await _close(writer)
            return
        target, headers = _parse_head(head)
        assert self.policy is not None
        websocket = headers.get("upgrade", "").lower() == "websocket"
        refused = denial(self.policy, headers, urlsplit(target).query, websocket)
        if refused is not None:
            writer.write(_refusal(refused[0], refused[1]))
            await _close(writer)
            return
        try:
            if self.inner_port is None:
                raise ConnectionRefusedError("viser not started yet")
            inner_reader, inner_writer = await asyncio.open_connection("127.0.0.1", self.inner_port)
        except OSError:
            writer.write(_refusal(503, "console not ready"))
            await _close(writer)
            return
        try:
            inner_writer.write(_marked(head, self.secret))
            await asyncio.gather(_pipe(reader, inner_writer), _answer(inner_reader, writer))
        finally:  # viser's end closed, also when the front door closes and cancels this (the
            # browser's end: `_handle`)
            with contextlib.suppress(ConnectionError, OSError, RuntimeError):
                inner_writer.close()


async def _answer(inner_reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
    """viser's answer with the page headers (no framing, scripts only from here) in its head."""
    try:
        head = await inner_reader.readuntil(b"\r\n\r\n")
    except (asyncio.IncompleteReadError, asyncio.LimitOverrunError, ConnectionError):
        await _close(writer)
        return
    writer.write(_with_headers(head, page_headers(CONSOLE_CSP)))
    await _pipe(inner_reader, writer)


async def _close(writer: asyncio.StreamWriter) -> None:
    with contextlib.suppress(ConnectionError, OSError):
        await writer.drain()
        writer.close()

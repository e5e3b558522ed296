"""The delay-line proxy: HTTP and WebSocket between operator and robot, delayed per message.

- HTTP: the request is held for the uplink delay, then forwarded (the upstream connection is
  opened only then: uvicorn drops idle keep-alives after 5 s, so we keep none longer than 2 s),
  and the response is held for the downlink delay. The upstream client is aiohttp: on loopback
  it costs ~0.6 ms a request against httpx's ~1.1 ms, and the proxy's budget is 1 ms. HTTP
  rides a reliable channel (TCP would retransmit): loss does not apply to it; a `drop`
  blackout answers 503.
- WebSocket: terminated on both sides; each data message is delayed in its direction and may be
  lost. Ping/pong is answered per hop, undelayed: with multi-second delays a delayed pong would
  trip the 20 s keepalive of websockets/uvicorn and kill healthy connections. Whether the robot
  is alive is judged end to end from the telemetry's age (`sent_at`), not from pings.
- A client's downlink messages wait in its outbox (ptwl/guard/outbox.py, the robot's rule too): a
  state not yet sent is replaced by the newer one, events wait up to 256, then the client is
  closed with 1013; so a client that never reads costs at most that, not a queue that grows.
- A schedule and a rate (latency/schedule.py) act per message like the delays. On a narrow or
  closed downlink a socket's states are parked, the newest replacing the one before, while its
  events wait their turn; and the robot is told the socket's share of the downlink
  (ptwl/guard/link_notice.py), so it sends no more states than the link carries.
- `/_link/...` is the control API: local, never delayed, never forwarded. GET /_link/outlook is
  the link's now and next (latency/outlook.py): what the console counts down from.
- Access (ptwl/guard/): Host, Origin and the token are checked on every route and socket before
  anything is delayed or forwarded; the upstream sees no Origin (it was judged here). Bodies
  are capped at 64 KiB and must be strict JSON.
- STOP always gets through: a request whose client goes away is cancelled upstream at once (an
  abandoned long-poll frees its connection), and the upstream pool has no connection cap, so
  200 open long-polls cannot queue a POST /api/stop behind them.
"""

import asyncio
import contextlib
import gc
import time
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from typing import Any
from urllib.parse import quote

import aiohttp
import websockets
from pydantic import ValidationError
from starlette.applications import Starlette
from starlette.requests import Request
from starlette.responses import JSONResponse, Response
from starlette.routing import Route, WebSocketRoute, request_response, websocket_session
from starlette.types import Receive, Scope, Send
from starlette.websockets import WebSocket, WebSocketDisconnect
from yarl import URL

from latency.clock import RealTimeDriver
from latency.delay_line import Dropped
from latency.link import Link
from ptwl.guard.access import AccessPolicy
from ptwl.guard.disconnect import client_gone
from ptwl.guard.json_body import JsonBodyError, parse_json
from ptwl.guard.link_notice import MIN_SHARE, notice_text
from ptwl.guard.outbox import Close, Outbox, is_state
from ptwl.guard.stack import install_guards

HOP_BY_HOP = {
    "connection",
    "keep-alive",
    "proxy-authenticate",
    "proxy-authorization",
    "te",
    "trailer",
    "trailers",
    "transfer-encoding",
    "upgrade",
    "host",
    "content-length",
    "content-encoding",
    "origin",  # judged here; the upstream would see the proxy's origin, not the page's
}
KEEPALIVE_EXPIRY_S = 2.0  # below uvicorn's 5 s idle timeout: never reuse a connection it dropped
UPSTREAM_TIMEOUT_S = 90.0  # long-polls wait up to 60 s upstream
IDEMPOTENT = {"GET", "HEAD", "OPTIONS", "PUT", "DELETE"}  # safe to retry on a dropped connection
CLOSE_UPSTREAM_LOST = 1012  # "service restart": reconnect


def _forward_headers(headers: Any) -> dict[str, str]:
    return {k: v for k, v in headers.items() if k.lower() not in HOP_BY_HOP}


def _problems(err: ValidationError) -> str:
    """`field: message; ...` for a profile update that does not validate."""
    parts = []
    for e in err.errors():
        where = ".".join(str(p) for p in e["loc"]) or "body"
        parts.append(f"{where}: {str(e['msg']).removeprefix('Value error, ')}")
    return "; ".join(parts)


def _released(loop: asyncio.AbstractEventLoop) -> tuple["asyncio.Future[None]", Callable[[], None]]:
    future: asyncio.Future[None] = loop.create_future()

    def deliver() -> None:
        if not future.done():  # the client may have gone away meanwhile
            future.set_result(None)

    return future, deliver


class LinkProxy:
    def __init__(self, upstream: str, link: Link, access: AccessPolicy) -> None:
        self.upstream = upstream.rstrip("/")
        self.upstream_url = URL(self.upstream)
        self.link = link
        self.access = access
        self.driver: RealTimeDriver | None = None
        self.http: aiohttp.ClientSession | None = None
        self._sockets = 0  # relayed WebSockets open now (they share the downlink)

    # ---------------------------------------------------------------- lifecycle
    @asynccontextmanager
    async def lifespan(self, app: Starlette) -> AsyncIterator[None]:
        self.driver = RealTimeDriver(self.link)
        self.driver.start()
        # Everything alive now lives as long as the proxy: keep it out of the collector's scans,
        # so a full collection pauses the release timer for well under a millisecond.
        gc.freeze()
        self.http = aiohttp.ClientSession(
            self.upstream,
            timeout=aiohttp.ClientTimeout(total=UPSTREAM_TIMEOUT_S, sock_connect=5.0),
            # limit=0: no pool cap, so open long-polls can never make a STOP wait for a connection.
            connector=aiohttp.TCPConnector(keepalive_timeout=KEEPALIVE_EXPIRY_S, limit=0),
            auto_decompress=False,
            skip_auto_headers=("User-Agent", "Accept-Encoding"),
        )
        try:
            yield
        finally:
            await self.http.close()
            await self.driver.stop()
            if self.link.recorder is not None:
                self.link.recorder.close()

    def app(self) -> Starlette:
        methods = ["GET", "POST", "PUT", "PATCH", "DELETE", "HEAD", "OPTIONS"]
        app = Starlette(
            routes=[
                Route("/_link/profile", self.profile, methods=["GET", "PUT"]),
                Route("/_link/stats", self.stats, methods=["GET"]),
                Route("/_link/outlook", self.outlook, methods=["GET"]),
                WebSocketRoute("/{path:path}", self.relay_websocket),
                Route("/{path:path}", self.forward_http, methods=methods),
            ],
            lifespan=self.lifespan,
        )
        # A path the catch-all's pattern cannot match (a decoded newline: `.` stops at it) is
        # still the robot's to answer, not Starlette's text/plain 404.
        forward, relay = request_response(self.forward_http), websocket_session(self.relay_websocket)

        async def unmatched(scope: Scope, receive: Receive, send: Send) -> None:
            await (relay if scope["type"] == "websocket" else forward)(scope, receive, send)

        app.router.default = unmatched
        install_guards(app, self.access)
        return app

    def _upstream_target(self, scope: Scope, query: str, scheme: str | None = None) -> URL | None:
        """The upstream URL for a request, or None if its path could name another host (`//host/...`
        is a network-path reference: joined naively, it leaves the upstream). The path goes on as
        the client encoded it: decoded and re-encoded, a %0A in it was lost (URL parsers drop
        newlines), and the robot would answer for another name."""
        path = scope.get("raw_path", b"").decode("latin-1") or quote(scope["path"])
        if not path.startswith("/") or path.startswith("//"):
            return None
        base = self.upstream_url if scheme is None else self.upstream_url.with_scheme(scheme)
        target = base.with_path(path, encoded=True)
        return target.with_query(query) if query else target

    # -------------------------------------------------------------- control API
    async def profile(self, request: Request) -> Response:
        if request.method == "PUT":
            try:
                update = parse_json(await request.body())
            except JsonBodyError as err:
                return JSONResponse({"detail": str(err)}, 422)
            if not isinstance(update, dict):
                return JSONResponse({"detail": "body must be a JSON object of profile fields"}, 422)
            try:
                profile = self.link.profile.merged(update)
            except ValidationError as err:
                return JSONResponse({"detail": _problems(err)}, 422)
            self.link.set_profile(profile)
        return JSONResponse(self.link.profile_view())

    async def outlook(self, request: Request) -> Response:
        return JSONResponse(self.link.outlook(time.time()))

    async def stats(self, request: Request) -> Response:
        return JSONResponse(self.link.stats_view())

    # --------------------------------------------------------------------- HTTP
    async def _through(self, direction: str, size: int, kind: str) -> Dropped | None:
        """Hold the caller until the link releases its message (None), or say why it was dropped."""
        future, deliver = _released(asyncio.get_running_loop())
        outcome = self.link.admit(direction, size, kind, deliver, lossy=False)
        if isinstance(outcome, Dropped):
            return outcome
        self._release_or_schedule(direction)
        await future
        return None

    def _release_or_schedule(self, direction: str) -> None:
        """Release what is already due (at zero delay: this message, without a task switch),
        else wake the driver to time it."""
        assert self.driver is not None
        due_at = self.link.next_release(direction)
        if due_at is not None and due_at <= self.link.clock():
            self.link.release_due(direction)
        self.driver.notify(direction)

    async def forward_http(self, request: Request) -> Response:
        target = self._upstream_target(request.scope, request.url.query)
        if target is None:
            return JSONResponse({"detail": f"no such path {request.url.path!r}"}, 404)
        body = await request.body()
        exchange = asyncio.create_task(self._exchange(request, target, body))
        gone = asyncio.create_task(client_gone(request))
        done, _ = await asyncio.wait({exchange, gone}, return_when=asyncio.FIRST_COMPLETED)
        if exchange not in done:
            # The client went away: stop holding its request and free the upstream connection.
            exchange.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await exchange
            return Response(status_code=499)
        gone.cancel()
        return exchange.result()

    async def _exchange(self, request: Request, target: URL, body: bytes) -> Response:
        head = sum(len(k) + len(v) for k, v in request.headers.items())
        dropped = await self._through("uplink", len(body) + head, "http_request")
        if dropped is not None:
            return JSONResponse({"detail": f"link dropped the request ({dropped.reason})"}, 503)
        try:
            status, headers, content = await self._upstream_request(request, target, body)
        except (aiohttp.ClientError, OSError, TimeoutError) as err:
            status, headers = 502, {"content-type": "application/json"}
            detail = f"upstream {self.upstream} unreachable: {type(err).__name__}: {err}".rstrip(": ")
            content = bytes(JSONResponse({"detail": detail}).body)
        dropped = await self._through("downlink", len(content), "http_response")
        if dropped is not None:
            return JSONResponse({"detail": f"link dropped the response ({dropped.reason})"}, 504)
        return Response(content, status_code=status, headers=headers)

    async def _upstream_request(
        self, request: Request, target: URL, body: bytes
    ) -> tuple[int, dict[str, str], bytes]:
        assert self.http is not None
        attempts = 2 if request.method in IDEMPOTENT else 1
        for attempt in range(attempts):
            try:
                async with self.http.request(
                    request.method,
                    target,
                    headers=_forward_headers(request.headers),
                    data=body,
                    allow_redirects=False,
                ) as upstream:
                    return upstream.status, _forward_headers(upstream.headers), await upstream.read()
            except aiohttp.ServerDisconnectedError:
                # A pooled connection the upstream had closed (e.g. it restarted): try a fresh one.
                if attempt + 1 == attempts:
                    raise
        raise AssertionError("unreachable")

    # ---------------------------------------------------------------- WebSocket
    async def relay_websocket(self, ws: WebSocket) -> None:
        scheme = "wss" if self.upstream_url.scheme == "https" else "ws"
        target = self._upstream_target(ws.scope, ws.url.query, scheme)
        if target is None:
            await ws.send_denial_response(JSONResponse({"detail": f"no such path {ws.url.path!r}"}, 404))
            return
        auth = ws.headers.get("authorization")
        try:
            upstream = await websockets.connect(
                str(target),
                additional_headers={"Authorization": auth} if auth else None,
                open_timeout=10.0,
                max_size=None,
                compression=None,  # the robot need not deflate what the link inflates at once
            )
        except websockets.InvalidStatus as err:
            await ws.send_denial_response(
                Response(err.response.body or b"", status_code=err.response.status_code)
            )
            return
        except (OSError, TimeoutError, websockets.WebSocketException) as err:
            detail = f"upstream {self.upstream} unavailable: {type(err).__name__}"
            await ws.send_denial_response(JSONResponse({"detail": detail}, 502))
            return
        await ws.accept()
        self._sockets += 1
        to_client = Outbox()  # bounded: states replaced, events up to a backlog, then 1013
        to_upstream: asyncio.Queue[Any] = asyncio.Queue()
        tasks = [
            asyncio.create_task(self._client_to_link(ws, to_upstream)),
            asyncio.create_task(self._link_to_upstream(upstream, to_upstream)),
            asyncio.create_task(self._upstream_to_link(upstream, to_client, to_upstream)),
            asyncio.create_task(self._link_to_client(ws, to_client)),
        ]
        try:
            await asyncio.wait([tasks[0], tasks[3]], return_when=asyncio.FIRST_COMPLETED)
        finally:
            for task in tasks:
                task.cancel()
            await asyncio.gather(*tasks, return_exceptions=True)
            await upstream.close()
            self._sockets -= 1
            self.link.forget("downlink", to_client)

    def _admit_ws(
        self, direction: str, message: Any, put: Callable[[Any], None], state_key: object = None
    ) -> None:
        """Into the link; a downlink state with its socket as `state_key`: replaced by the next
        one while it waits for the wire (latency/delay_line.py)."""
        size = len(message) if isinstance(message, str | bytes) else 0
        if state_key is not None and is_state(message):
            self.link.admit(direction, size, "ws_state", lambda: put(message), replace_key=state_key)
        else:
            self.link.admit(direction, size, "ws", lambda: put(message))
        self._release_or_schedule(direction)

    def _tell_downlink(self, told: list[float | None], to_upstream: "asyncio.Queue[Any]") -> None:
        """Tell the robot this socket's share of the downlink when it changes (at the robot's
        end, undelayed: ptwl/guard/link_notice.py)."""
        rate = self.link.rate_now("downlink")
        share = None if rate is None else max(MIN_SHARE, rate / max(1, self._sockets))
        if share != told[0]:
            told[0] = share
            to_upstream.put_nowait(notice_text(share))

    async def _client_to_link(self, ws: WebSocket, to_upstream: "asyncio.Queue[Any]") -> None:
        with contextlib.suppress(WebSocketDisconnect):
            while True:
                message = await ws.receive()
                if message["type"] == "websocket.disconnect":
                    return
                data = message.get("text") if message.get("text") is not None else message.get("bytes")
                if data is not None:
                    self._admit_ws("uplink", data, to_upstream.put_nowait)

    async def _link_to_upstream(self, upstream: Any, to_upstream: "asyncio.Queue[Any]") -> None:
        with contextlib.suppress(websockets.ConnectionClosed):
            while True:
                await upstream.send(await to_upstream.get())

    async def _upstream_to_link(
        self, upstream: Any, to_client: Outbox, to_upstream: "asyncio.Queue[Any]"
    ) -> None:
        code, reason = CLOSE_UPSTREAM_LOST, "upstream connection lost"
        told: list[float | None] = [None]  # the robot starts unlimited
        self._tell_downlink(told, to_upstream)
        try:
            async for message in upstream:
                if to_client.too_slow:
                    return  # its socket is closing: what comes now would only wait
                self._tell_downlink(told, to_upstream)  # a window's rate, or a socket more or less
                self._admit_ws("downlink", message, to_client.put, state_key=to_client)
            code = upstream.close_code or 1000
            reason = f"upstream closed: {upstream.close_reason or 'normal closure'}"
        except websockets.ConnectionClosed:
            pass
        # The close travels the downlink behind the data already in flight.
        assert self.driver is not None
        self.link.admit("downlink", 0, "ws_close", lambda: to_client.put(Close(code, reason)), lossy=False)
        self.driver.notify("downlink")

    async def _link_to_client(self, ws: WebSocket, to_client: Outbox) -> None:
        with contextlib.suppress(WebSocketDisconnect, RuntimeError):
            while True:
                message = await to_client.get()
                if isinstance(message, Close):
                    code = message.code
                    valid = code if 1000 <= code < 5000 and code not in (1005, 1006, 1015) else 1011
                    await ws.close(valid, message.reason[:120])
                    return
                if isinstance(message, bytes):
                    await ws.send_bytes(message)
                else:
                    await ws.send_text(message)

"""AccessGuard: the access policy in front of an ASGI app, for every HTTP route and WebSocket.

Checks run in order Host (400), Origin (403), token (401/403), before the app sees the request,
so no route can forget them (docs and openapi.json included when a token is set). Every answer
it lets out, a refusal too, carries the page headers (ptwl/guard/page_headers.py: no framing, scripts
only from the page's own origin).
"""

from urllib.parse import parse_qs

from starlette.types import ASGIApp, Message, Receive, Scope, Send

from ptwl.guard.access import AccessPolicy, bearer
from ptwl.guard.page_headers import API_CSP, with_page_headers
from ptwl.guard.respond import send_json


def _headers(scope: Scope) -> dict[str, str]:
    return {k.decode("latin-1").lower(): v.decode("latin-1") for k, v in scope.get("headers", [])}


def denial(
    policy: AccessPolicy, headers: dict[str, str], query: str, websocket: bool
) -> tuple[int, str, dict[str, str]] | None:
    """(status, detail, extra headers) if a request with these (lowercase) headers may not pass."""
    if (problem := policy.host_problem(headers.get("host"))) is not None:
        return 400, problem, {}
    if (problem := policy.origin_problem(headers.get("origin"))) is not None:
        return 403, problem, {}
    presented = bearer(headers.get("authorization"))
    if presented is None and websocket:
        values = parse_qs(query).get("token")  # browsers cannot set headers on a WebSocket
        presented = values[0] if values else None
    if (token := policy.token_problem(presented)) is not None:
        status, detail = token
        return status, detail, ({"www-authenticate": "Bearer"} if status == 401 else {})
    return None


class AccessGuard:
    def __init__(self, app: ASGIApp, policy: AccessPolicy) -> None:
        self.app = app
        self.policy = policy

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        send = _with_page_headers(send)
        query = scope.get("query_string", b"").decode("latin-1")
        refused = denial(self.policy, _headers(scope), query, scope["type"] == "websocket")
        if refused is None:
            await self.app(scope, receive, send)
            return
        status, detail, extra = refused
        if scope["type"] == "http":
            await send_json(send, status, {"detail": detail}, extra)
        elif "websocket.http.response" in scope.get("extensions", {}):
            await send_json(_as_websocket_denial(send), status, {"detail": detail}, extra)
        else:
            await send({"type": "websocket.close", "code": 4000 + status, "reason": detail[:120]})


def _with_page_headers(send: Send) -> Send:
    async def wrapped(message: Message) -> None:
        if message["type"] in ("http.response.start", "websocket.http.response.start"):
            message = {**message, "headers": with_page_headers(list(message.get("headers", [])), API_CSP)}
        await send(message)

    return wrapped


def _as_websocket_denial(send: Send) -> Send:
    """ASGI's WebSocket denial response: the same messages, prefixed `websocket.`."""

    async def wrapped(message: Message) -> None:
        await send({**message, "type": "websocket." + message["type"]})

    return wrapped
